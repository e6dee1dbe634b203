"""The ``ray`` placement's settings, registration and unavailability (no cluster needed)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap
from typing import Any

import pytest

import multicosim as mcs
from multicosim.placement import ParticipantProgram, Placement, ProgramSpec, get_placement
from multicosim.ray import ENV_ADDRESS, LocalCluster, Ray, RayParticipant


def test_the_placement_is_registered_as_ray(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ENV_ADDRESS, raising=False)
    placement = get_placement("ray")
    assert isinstance(placement, Ray)
    assert isinstance(placement, Placement)
    assert placement.name == "ray"
    assert not placement.in_process
    assert placement.address is None
    program = ParticipantProgram("multicosim.rover:kinematic_world", None, "world")
    assert isinstance(placement.participant(program), RayParticipant)


def test_the_registered_placement_takes_its_address_from_the_environment(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv(ENV_ADDRESS, " 10.0.0.5:6379 ")
    assert get_placement("ray").address == "10.0.0.5:6379"  # type: ignore[attr-defined]
    assert Ray("auto").address == "auto"  # an address given wins
    monkeypatch.setenv(ENV_ADDRESS, "head-without-port")
    with pytest.raises(mcs.ConfigurationError) as info:
        get_placement("ray")
    assert info.value.field == ENV_ADDRESS
    assert info.value.value == "head-without-port"


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"address": ""}, "address"),
        ({"address": 6379}, "address"),
        ({"address": "head:0"}, "address"),
        ({"address": "head:99999"}, "address"),
        ({"num_cpus": -1}, "num_cpus"),
        ({"num_cpus": float("nan")}, "num_cpus"),
        ({"num_cpus": True}, "num_cpus"),
        ({"strategy": "PACK"}, "strategy"),
        ({"place_timeout": 0}, "place_timeout"),
        ({"options": ["world"]}, "options"),
        ({"options": {"world": 1}}, "options"),
        ({"options": {"world": {"lifetime": "detached"}}}, "options['world']"),
    ],
)
def test_bad_settings_name_the_field(kwargs: dict[str, Any], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        Ray(**kwargs)
    assert info.value.field == field
    assert "expected" in str(info.value)


def test_a_ray_client_address_is_refused_with_the_reason() -> None:
    with pytest.raises(mcs.ConfigurationError, match="cannot reach the simulation's coordinator"):
        Ray("ray://head:10001")


def test_actors_are_never_restarted_whatever_the_options() -> None:
    placement = Ray(num_cpus=0.5, options={"world": {"resources": {"big": 1}, "num_cpus": 2}})
    world = placement.actor_options("world")
    assert world["resources"] == {"big": 1}
    assert world["num_cpus"] == 2
    assert world["scheduling_strategy"] == "SPREAD"
    assert world["max_restarts"] == 0
    assert placement.actor_options("controller")["num_cpus"] == 0.5


def test_a_ray_component_needs_a_ray_simulator() -> None:
    simulator = mcs.ProcessSimulator()
    program = ParticipantProgram("multicosim.rover:kinematic_world", None, "world")
    simulator.add(Ray().participant(program))
    with pytest.raises(mcs.ConfigurationError, match="a simulator of the ray placement") as info:
        simulator.start()
    assert info.value.field == "placement"


def _run(code: str) -> dict[str, Any]:
    """Run ``code`` in a fresh interpreter (no Ray connection yet); what it printed as JSON."""
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=120,
        env={k: v for k, v in os.environ.items() if k != ENV_ADDRESS},
    )
    assert done.returncode == 0, done.stderr[-3000:]
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


UNAVAILABLE = """
    import json, sys
    {setup}
    from multicosim import PlacementUnavailableError
    from multicosim.ray import Ray
    try:
        Ray({address!r}).prepare()
    except PlacementUnavailableError as exc:
        print(json.dumps({{"message": str(exc), "detail": exc.detail}}))
"""


def test_no_cluster_at_the_address_is_unavailable_at_once() -> None:
    with socket.socket() as s:  # a port where nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    found = _run(UNAVAILABLE.format(setup="", address=f"127.0.0.1:{port}"))
    assert found["message"] == f"no Ray cluster at 127.0.0.1:{port}"
    assert "ray start --head" in found["detail"]


def test_without_ray_the_placement_is_unavailable_and_says_what_to_install() -> None:
    found = _run(UNAVAILABLE.format(setup="sys.modules['ray'] = None", address=None))
    assert found["message"] == "Ray is not installed"
    assert "pip install 'multicosim[ray]'" in found["detail"]


def test_naming_the_placement_does_not_import_ray() -> None:
    found = _run(
        """
        import json, sys
        from multicosim.placement import get_placement
        import multicosim.rover as rover
        rover.Rover(fidelity="medium", placement="ray")
        print(json.dumps({"ray": "ray" in sys.modules, "placement": get_placement("ray").name}))
        """
    )
    assert found == {"ray": False, "placement": "ray"}


def test_a_local_cluster_checks_its_size() -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        LocalCluster(nodes=0)
    assert info.value.field == "nodes"


def test_the_placement_refuses_external_programs() -> None:
    spec = ProgramSpec(name="sitl", command=["px4"], image="px4:sitl", image_command=["px4"])
    with pytest.raises(
        mcs.ConfigurationError, match="'ray' runs participants and firmware"
    ) as info:
        Ray().program(spec)
    assert info.value.field == "placement"
    assert "'sitl'" in str(info.value)
