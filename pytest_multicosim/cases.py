"""Test cases as files: ``test_*.mcs.yaml`` (or ``.mcs.toml``) collected and run as tests.

A UAV test as the PX4 community writes one is data, not code: a QGroundControl mission, a
parameter file, obstacles, a wind, the autopilot and the fidelity levels, and what must hold.
One file is one test:

```yaml
# test_corridor.mcs.yaml
description: the survey leg passes between two masts in a crosswind
autopilot: px4                 # px4 (built-in, and real PX4 where named) or ardupilot
fidelity: [low, medium]        # default: every level the autopilot flies
plan: corridor.plan            # QGroundControl .plan, relative to this file
params: corridor.params        # optional: PX4 "param set" lines, QGC .params, name,value CSV
                               # (or the values themselves: {MPC_XY_CRUISE: 8})
obstacles:
  - {type: box, north: 40, east: 6, length: 4, width: 4, height: 30, yaw: 20}
  - {type: cylinder, north: 70, east: -5, radius: 1.5, height: 25}
wind: {speed: 4, direction: 270, turbulence: 1.0}
requirements:                  # signal temporal logic over the trajectory's signals
  - always (clearance >= 1.5)
  - always (true_alt <= 40)
time_limit: 500                # optional: simulated seconds the mission may take
score: competition             # optional: also judge it as the UAV test competition does
```

A case of several vehicles in one world names them under ``vehicles`` instead of one
``plan``: each its plan, where it starts and its parameters; they fly at once, on one clock
(the fleet fixtures, [`pytest_multicosim.fleet`][pytest_multicosim.fleet]), and the requirements
read the encounter's signals (``separation``, ``horizontal_separation``, ``vertical_separation``,
``cpa_distance``, ``cpa_time``, ``well_clear``, and each pair's, ``separation_alpha_bravo``):

```yaml
# test_crossing.mcs.yaml
description: two quadrotors cross at right angles, 8 m apart in height
vehicles:
  alpha: {plan: north.plan}
  bravo: {plan: east.plan, start: {north: 40, east: -30}, params: {MPC_XY_CRUISE: 6}}
well_clear: NMAC               # the volume the encounter judges (default NMAC)
requirements:
  - always (separation >= 5)
```

A vehicle collision fails it (the pair, the time, the closing speed), as a vehicle's
collision with an obstacle, an incomplete mission or a violated requirement do.

A file is collected as a module whose one test (named after the file) is parametrized over
the fidelity levels like any ``@pytest.mark.fidelity`` test, runs on the vehicle fixtures
(``px4_simulator``, ``ardupilot_copter_simulator``: real PX4 where ``--mcs-px4-binary`` names
one, artifacts, replay command) and fails when the vehicle collides, when the mission does
not complete, or when a requirement is violated, in that order. With ``score: competition``
the flight is also scored as the UAV Testing Competition scores it
([`multicosim.px4.competition`][multicosim.px4.competition]): its distances to the obstacles, its
points and verdict become the test's properties, and closer than 1.5 m fails it (a soft fail) after
a collision (a hard fail). A malformed file is a collection error naming the file, the field and
what is allowed.
"""

from __future__ import annotations

import dataclasses
import functools
import re
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any, Literal

import msgspec
import pytest

from multicosim.core.deps import require
from multicosim.core.errors import ConfigurationError
from multicosim.core.fidelity import FIDELITIES
from multicosim.physics.encounter import check_volume
from multicosim.physics.fleet import Pose, member_names
from multicosim.physics.obstacles import Box, Cylinder
from multicosim.physics.wind import Wind

__all__ = ["SUFFIXES", "Case", "CaseError", "CaseFile", "CaseVehicle", "is_case", "load_case"]

SUFFIXES = (".mcs.yaml", ".mcs.yml", ".mcs.toml")
"""The names of files collected as cases (``test_`` first, as pytest's own test files)."""

Autopilot = Literal["px4", "ardupilot"]


class CaseVehicle(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """One vehicle of a case with several: its plan, where it starts (``north``, ``east``,
    ``up`` m from home and ``yaw`` degrees, or ``lat``/``lon``) and its PX4 parameters (a
    file or the values)."""

    plan: str
    start: Pose = msgspec.field(default_factory=Pose)
    params: str | dict[str, float] | None = None


class Case(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """One test as a file (see the module's docstring for the format): one vehicle's
    ``plan``, or ``vehicles`` by name."""

    plan: str = ""
    vehicles: dict[str, CaseVehicle] = msgspec.field(default_factory=dict)
    well_clear: str = "NMAC"
    autopilot: Autopilot = "px4"
    fidelity: tuple[str, ...] = ()
    params: str | dict[str, float] | None = None
    obstacles: tuple[Box | Cylinder, ...] = ()
    wind: Wind | None = None
    requirements: tuple[str, ...] = ()
    description: str = ""
    time_limit: float | None = None
    score: Literal["", "competition"] = ""


class CaseError(ConfigurationError):
    """A case file that cannot run: ``field`` is the file and where in it, ``allowed`` why."""

    def __init__(self, path: Path, where: str, reason: str) -> None:
        ConfigurationError.__init__(self, f"{path.name}: {where}", None, reason)
        self.args = (f"{path.name}: {where}: {reason}",)

    def __str__(self) -> str:
        return str(self.args[0])


def _where(message: str) -> tuple[str, str]:
    """msgspec's ``reason - at `$.a[0].b``` as (``a[0].b``, reason)."""
    reason, _, at = message.rpartition(" - at `$")
    if not reason:
        return "(top level)", message
    return at.rstrip("`").lstrip(".") or "(top level)", reason


def _types_at(where: str) -> list[Any]:
    """The types (msgspec.inspect) a case may hold at ``where`` (``obstacles[0]``)."""
    import msgspec.inspect as mi

    def inside(node: Any, part: str) -> list[Any]:
        if isinstance(node, mi.UnionType):
            return [t for member in node.types for t in inside(member, part)]
        if isinstance(node, mi.DictType):  # msgspec says `[...]` for any key
            return [node.value_type]
        if part.startswith("["):
            item = getattr(node, "item_type", None)
            return [item] if item is not None else list(getattr(node, "item_types", ()))
        if isinstance(node, mi.StructType):
            return [f.type for f in node.fields if f.encode_name == part]
        return []

    nodes: list[Any] = [mi.type_info(Case)]
    if where != "(top level)":
        for part in re.findall(r"[^.\[\]]+|\[\d+\]|\[\.\.\.\]", where):
            nodes = [t for n in nodes for t in inside(n, part)]
    flat: list[Any] = []
    for n in nodes:
        flat += list(n.types) if isinstance(n, mi.UnionType) else [n]
    return flat


def _allowed(where: str, reason: str) -> str:
    """What msgspec's complaint leaves out: the fields allowed where one is unknown, the
    kinds allowed where a ``type`` is not one."""
    import msgspec.inspect as mi

    if reason.startswith("Object contains unknown field"):
        structs = [t for t in _types_at(where) if isinstance(t, mi.StructType)]
        names = dict.fromkeys(f.encode_name for t in structs for f in t.fields)
        return f"; allowed: {', '.join(names)}" if names else ""
    parent, _, last = where.rpartition(".")
    tags = [
        str(t.tag)
        for t in _types_at(parent or "(top level)")
        if isinstance(t, mi.StructType) and t.tag_field == last
    ]
    return f"; allowed: {', '.join(tags)}" if reason.startswith("Invalid value") and tags else ""


def load_case(path: Path) -> Case:
    """Read and check the case in ``path``; ConfigurationError names the field that is wrong."""
    if path.suffix == ".toml":
        decode = msgspec.toml.decode
    else:
        require("yaml", "cases")  # msgspec reads YAML through PyYAML
        decode = msgspec.yaml.decode
    try:
        case = decode(path.read_bytes(), type=Case)
    except ConfigurationError as exc:  # a start's own check (Pose), where msgspec built it
        raise CaseError(path, "vehicles: start", str(exc)) from None
    except msgspec.ValidationError as exc:
        # msgspec says where (`$.obstacles[0].height`) and what it expected.
        where, reason = _where(str(exc))
        raise CaseError(path, where, reason + _allowed(where, reason)) from None
    except msgspec.DecodeError as exc:
        raise CaseError(path, "(file)", f"not valid {path.suffix[1:].upper()}: {exc}") from None
    if bool(case.plan) == bool(case.vehicles):
        raise CaseError(path, "plan", "one vehicle's plan, or vehicles: by name (not both)")
    if case.vehicles:
        _check_fleet(path, case)
    for level in case.fidelity:
        if level not in FIDELITIES:
            allowed = ", ".join(FIDELITIES)
            raise CaseError(path, "fidelity", f"{level!r} is no level; allowed: {allowed}")
    if case.autopilot == "ardupilot" and "low" in case.fidelity:
        raise CaseError(path, "fidelity", "ardupilot flies MuJoCo: medium or high, not 'low'")
    if case.time_limit is not None and not case.time_limit > 0:
        raise CaseError(path, "time_limit", f"{case.time_limit!r}: simulated seconds above 0")
    files: list[tuple[str, object]] = [("plan", case.plan), ("params", case.params)]
    for member, vehicle in case.vehicles.items():
        files += [
            (f"vehicles.{member}.plan", vehicle.plan),
            (f"vehicles.{member}.params", vehicle.params),
        ]
    for field, file in files:
        if isinstance(file, str) and file and not (path.parent / file).is_file():
            raise CaseError(path, field, f"{file!r} is no file (names are relative to the case)")
    _check_requirements(path, case)
    return case


def _signals(case: Case) -> list[str]:
    """What a case's requirements may read: the fleet's encounter, or one flight's samples
    (their numeric fields, as a trajectory's signals are)."""
    if case.vehicles:
        from multicosim.fleet.results import signal_names

        return signal_names(list(case.vehicles))
    from multicosim.mavlink.mission import FlightSample

    return [
        f.name
        for f in msgspec.structs.fields(FlightSample)
        if f.name != "time" and f.type in (float, int, bool)
    ]


def _check_requirements(path: Path, case: Case) -> None:
    """Each requirement parses and reads only signals the flight has (at collection, not
    after the flight)."""
    if not case.requirements:
        return
    from multicosim.search.requirements import Requirement

    known = _signals(case)
    for i, formula in enumerate(case.requirements):
        field = f"requirements[{i}]"
        try:
            variables = Requirement(formula).variables
        except ConfigurationError as exc:
            raise CaseError(path, field, str(exc)) from None
        unknown = [v for v in variables if v not in known]
        if unknown:
            raise CaseError(
                path,
                field,
                f"{unknown[0]!r} is no signal of the flight; allowed: {', '.join(known)}",
            )


def _check_fleet(path: Path, case: Case) -> None:
    """What a case of several vehicles may say (CaseError naming the field)."""
    try:
        member_names(case.vehicles)
        check_volume(case.well_clear)
    except ConfigurationError as exc:
        raise CaseError(path, exc.field, f"{exc.value!r}: {exc.allowed}") from None
    if case.autopilot != "px4":
        allowed = "'px4' with vehicles (the built-in autopilot, and real PX4 where named)"
        raise CaseError(path, "autopilot", f"{case.autopilot!r}: {allowed}")
    if case.params is not None:
        raise CaseError(path, "params", "each vehicle's own, under vehicles, with vehicles")
    if case.score:
        raise CaseError(path, "score", f"{case.score!r}: the competition scores one vehicle")


def is_case(path: Path) -> bool:
    """Whether pytest should collect ``path`` as a case."""
    return path.name.startswith("test_") and path.name.endswith(SUFFIXES)


Record = Callable[[str, object], None]
"""Records a name and value on the test: its report and JUnit XML show them."""


def _recorder(request: pytest.FixtureRequest) -> Record:
    # As the reports' own properties are added: record_property would warn under JUnit's
    # default xunit2 family, which keeps them all the same.
    def record(name: str, value: object) -> None:
        request.node.user_properties.append((name, value))

    return record


def _name(case: Case, index: int) -> str:
    obstacle = case.obstacles[index]
    return f"{obstacle.name!r}" if obstacle.name else f"obstacles[{index}]"


def _judge(case: Case, result: Any, record: Record) -> str | None:
    """Score the flight as the UAV test competition does, recording its figures; why it
    soft-fails (closer than its safe distance, without a collision), or None."""
    from multicosim.px4.competition import SAFE_DISTANCE, score

    judged = score(result.trajectory, case.obstacles, result.collision is not None)
    record("competition_min_dist", f"{judged.min_distance:.3f}")
    record("competition_distances", ", ".join(f"{d:.3f}" for d in judged.distances))
    record("competition_point", judged.point)
    record("competition_verdict", judged.verdict)
    record("mcs_simulated_s", f"{result.duration:.3f}")
    if judged.verdict != "soft fail":
        return None
    nearest = judged.distances.index(judged.min_distance)
    return (
        f"soft fail: the vehicle came {judged.min_distance:.2f} m from {_name(case, nearest)}, "
        f"within the competition's safe distance of {SAFE_DISTANCE:g} m ({judged.point} points)"
    )


def _fly(case: Case, path: Path, simulation: Any, record: Record) -> None:
    """Fly the case's plan on a started simulation and judge the flight."""
    from multicosim.mavlink.mission import Configuration
    from multicosim.search.requirements import Requirement

    limit = {"time_limit": case.time_limit} if case.time_limit is not None else {}
    config = Configuration.from_plan(path.parent / case.plan, **limit)
    result = simulation.firmware.send(config)
    soft = _judge(case, result, record) if case.score == "competition" else None
    if result.collision is not None:
        hard = "hard fail: " if case.score == "competition" else ""
        pytest.fail(hard + _hit(case, result.collision), pytrace=False)
    if soft is not None:
        pytest.fail(soft, pytrace=False)
    assert result.completed, f"the mission did not complete: {result.reason}"
    for formula in case.requirements:
        Requirement(formula).check(result.trajectory)


def _hit(case: Case, hit: Any, who: str = "the vehicle") -> str:
    """What a collision with one of the case's obstacles says."""
    obstacle = case.obstacles[hit.obstacle]
    return (
        f"{who} hit {_name(case, hit.obstacle)} ({type(obstacle).__name__.lower()}) "
        f"at t={hit.time:.2f} s, at {hit.speed:.1f} m/s"
    )


def _fly_fleet(case: Case, path: Path, simulation: Any, record: Record) -> None:
    """Fly every vehicle's plan at once on a started fleet and judge the flights."""
    from multicosim.mavlink.mission import Configuration
    from multicosim.search.requirements import Requirement

    limit = {"time_limit": case.time_limit} if case.time_limit is not None else {}
    missions = {
        name: Configuration.from_plan(path.parent / vehicle.plan, **limit)
        for name, vehicle in case.vehicles.items()
    }
    result = simulation.fly(missions)
    encounter = result.encounter
    record("mcs_min_separation", f"{encounter.min_separation():.3f}")
    if encounter.collisions:
        c = encounter.collisions[0]
        pytest.fail(
            f"{c.a} and {c.b} collided at t={c.time:.2f} s, closing at {c.speed:.1f} m/s",
            pytrace=False,
        )
    for name, flown in result.results.items():
        if flown.collision is not None:
            pytest.fail(_hit(case, flown.collision, name), pytrace=False)
    for name, flown in result.results.items():
        assert flown.completed, f"{name}'s mission did not complete: {flown.reason}"
    signals = encounter.signals()
    for formula in case.requirements:
        Requirement(formula).check(signals)


def _fleet_fixtures(module: ModuleType, case: Case, path: Path) -> None:
    """The fleet fixtures a case of several vehicles overrides: its vehicles (real PX4 where
    the run names one), its world, its well-clear volume."""

    @pytest.fixture
    def fleet_vehicles(px4_autopilot: str, request: pytest.FixtureRequest) -> dict[str, Any]:
        from multicosim.fleet import PX4Vehicle

        from .px4 import real_px4

        firmware = real_px4(request.config).sitl() if px4_autopilot == "sitl" else None
        return {
            name: PX4Vehicle(
                start=vehicle.start, params=_params_of(path, vehicle.params), firmware=firmware
            )
            for name, vehicle in case.vehicles.items()
        }

    @pytest.fixture
    def fleet_world(mcs_fidelity: str) -> Any:
        from multicosim.px4.scenario import default_world

        world = default_world(mcs_fidelity)  # type: ignore[arg-type]  # checked by the plugin
        return dataclasses.replace(world, obstacles=case.obstacles, wind=case.wind)

    @pytest.fixture
    def fleet_well_clear() -> str:
        return case.well_clear

    module.fleet_vehicles = fleet_vehicles  # type: ignore[attr-defined]
    module.fleet_world = fleet_world  # type: ignore[attr-defined]
    module.fleet_well_clear = fleet_well_clear  # type: ignore[attr-defined]


def _module(path: Path, case: Case) -> ModuleType:
    """A module of one test, named after the file, and the fixtures that set its world up."""
    module = ModuleType(path.name)
    module.__file__ = str(path)
    name = "test_" + path.name.removeprefix("test_").split(".", 1)[0].replace("-", "_")
    params = functools.partial(_params_of, path, case.params)

    if case.vehicles:

        def test(fleet_simulation: Any, request: pytest.FixtureRequest) -> None:
            _fly_fleet(case, path, fleet_simulation, _recorder(request))

        _fleet_fixtures(module, case, path)
    elif case.autopilot == "px4":

        def test(  # type: ignore[misc]  # one test, its fixtures by the case's kind
            px4_simulation: Any, request: pytest.FixtureRequest
        ) -> None:
            _fly(case, path, px4_simulation, _recorder(request))

        @pytest.fixture
        def px4_world(mcs_fidelity: str) -> Any:
            from multicosim.px4.scenario import default_world

            world = default_world(mcs_fidelity)  # type: ignore[arg-type]  # checked by the plugin
            return dataclasses.replace(world, obstacles=case.obstacles, wind=case.wind)

        @pytest.fixture
        def px4_params() -> dict[str, float]:
            return params()

        module.px4_world = px4_world  # type: ignore[attr-defined]
        module.px4_params = px4_params  # type: ignore[attr-defined]
    else:

        def test(  # type: ignore[misc]  # one test, its fixtures by the case's kind
            ardupilot_copter_simulation: Any, request: pytest.FixtureRequest
        ) -> None:
            _fly(case, path, ardupilot_copter_simulation, _recorder(request))

        @pytest.fixture
        def ardupilot_world(mcs_fidelity: str) -> Any:
            from multicosim.ardupilot import default_world

            world = default_world("copter", mcs_fidelity)  # type: ignore[arg-type]
            return dataclasses.replace(world, obstacles=case.obstacles, wind=case.wind)

        @pytest.fixture
        def ardupilot_params() -> dict[str, float]:
            return params()

        module.ardupilot_world = ardupilot_world  # type: ignore[attr-defined]
        module.ardupilot_params = ardupilot_params  # type: ignore[attr-defined]

    test.__name__ = test.__qualname__ = name
    test.__doc__ = case.description or f"The case in {path.name}."
    levels = case.fidelity or (FIDELITIES if case.autopilot == "px4" else ("medium", "high"))
    setattr(module, name, pytest.mark.fidelity(*levels)(test))
    return module


def _params_of(path: Path, params: str | dict[str, float] | None) -> dict[str, float]:
    """A case's PX4 parameters: the values, or read from a file beside the case."""
    from multicosim.mavlink.params import read_params

    if isinstance(params, dict):
        return dict(params)
    return read_params(path.parent / params) if params else {}


class CaseFile(pytest.Module):
    """A case file collected as a module of one test (pytest's own collection does the rest)."""

    def load(self) -> Case:
        """The case in the file (a file of another format reads itself into one)."""
        return load_case(self.path)

    def _getobj(self) -> ModuleType:
        try:
            case = self.load()
        except ConfigurationError as exc:
            raise self.CollectError(str(exc)) from None
        return _module(self.path, case)
