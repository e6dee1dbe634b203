"""The public surface: exported names, light imports, optional dependencies."""

from __future__ import annotations

import subprocess
import sys

import pytest

import multicosim as mcs

EXPECTED = {
    "CampaignInterrupted",
    "ComponentCheckError",
    # The paper's container classes, at the top where its listings take them from.
    "AttachedComponent",
    "AttachedNode",
    "ContainerComponent",
    "ContainerFirmwareNode",
    "ContainerNode",
    "ContainerSimulation",
    "ContainerSimulator",
    "FirmwareComponent",
    "EngineUnavailableError",
    "FIDELITIES",
    "Fidelity",
    "FormulaError",
    "ImageMissingError",
    "PhysicsDivergedError",
    "Requirement",
    "RequirementViolation",
    "ScenarioSimulation",
    "Scenario",
    "Placement",
    "PlacementUnavailableError",
    "CommunicationNode",
    "Component",
    "ConfigurationError",
    "DependencyMissingError",
    "Firmware",
    "FirmwareContext",
    "ProcessFirmwareNode",
    "ProcessFirmwareComponent",
    "ThreadFirmwareComponent",
    "InProcessFirmwareComponent",
    "InProcessFirmwareNode",
    "SelfContainedSimulation",
    "SelfContainedSimulator",
    "LocalEnvironment",
    "Message",
    "MessageTypeError",
    "MulticosimError",
    "Node",
    "NodeCrashedError",
    "NodeError",
    "NodeId",
    "NodeStartError",
    "NodeTimeoutError",
    "Participant",
    "InProcessComponent",
    "InProcessNode",
    "ProcessComponent",
    "ProcessNode",
    "ProcessSimulation",
    "ProcessSimulator",
    "RemoteError",
    "Simulation",
    "SimulationStopped",
    "Simulator",
    "StepContext",
    "Subscription",
    "TraceError",
    "TransportError",
    "__version__",
    "firmware",
    "run_participant",
    "serve",
}


def test_exported_names_are_the_intended_ones() -> None:
    assert set(mcs.__all__) == EXPECTED
    for name in mcs.__all__:
        assert getattr(mcs, name) is not None, name


def test_the_papers_names_are_at_the_top_and_are_the_docker_packages() -> None:
    import multicosim.docker as docker

    # Every name the paper's listings take from ``mcs.`` (its interfaces and its classes).
    for name in (
        "Node",
        "CommunicationNode",
        "Component",
        "Simulator",
        "Simulation",
        "NodeId",
        "ContainerSimulator",
        "ContainerComponent",
        "FirmwareComponent",
        "AttachedComponent",
    ):
        assert name in mcs.__all__, name
    for name in ("ContainerSimulator", "ContainerComponent", "FirmwareComponent"):
        assert getattr(mcs, name) is getattr(docker, name)


def test_import_multicosim_loads_no_docker_physics_zeromq_or_mavlink() -> None:
    code = (
        "import sys, multicosim; "
        "print([m for m in ('docker', 'mujoco', 'zmq', 'pymavlink') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_unknown_attribute_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'Nope'"):
        _ = mcs.Nope


def test_import_multicosim_stays_light() -> None:
    code = (
        "import sys, multicosim as mcs; mcs.ProcessSimulator; "
        "heavy = [m for m in ('docker', 'mujoco', 'mcap', 'pymavlink', 'rtamt') "
        "if m in sys.modules]; print(heavy)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_every_error_derives_from_the_root() -> None:
    for name in mcs.__all__:
        obj = getattr(mcs, name)
        if isinstance(obj, type) and issubclass(obj, Exception):
            assert issubclass(obj, mcs.MulticosimError), name


def test_dependency_missing_names_the_extra() -> None:
    err = mcs.DependencyMissingError("mujoco", "mujoco")
    assert "pip install 'multicosim[mujoco]'" in str(err)
    assert isinstance(err, ImportError)


def test_configuration_error_names_field_value_and_allowed() -> None:
    err = mcs.ConfigurationError("timestep", -1.0, "a number in (0, 0.1]")
    assert (err.field, err.value, err.allowed) == ("timestep", -1.0, "a number in (0, 0.1]")
    assert str(err) == "timestep=-1.0 is invalid: expected a number in (0, 0.1]"


def test_version_matches_package_metadata() -> None:
    from importlib.metadata import version

    assert mcs.__version__ == version("multicosim")


def test_require_names_the_extra_for_a_missing_module() -> None:
    from multicosim.core.deps import require

    assert require("json", "core").dumps(1) == "1"
    with pytest.raises(mcs.DependencyMissingError, match=r"multicosim\[trace\]") as info:
        require("surely_not_installed_module", "trace")
    assert (info.value.module, info.value.extra) == ("surely_not_installed_module", "trace")


@pytest.mark.parametrize(
    "old",
    ["ParticipantComponent", "FirmwareNode", "InProcessSimulator", "InProcessSimulation"],
)
def test_round_one_aliases_are_gone(old: str) -> None:
    with pytest.raises(AttributeError, match=f"no attribute {old!r}"):
        getattr(mcs, old)


def test_the_papers_names_are_aliases() -> None:
    import multicosim.docker

    assert multicosim.docker.FirmwareComponent is multicosim.docker.ContainerFirmwareComponent


FMI_EXPECTED = {
    "FMU",
    "FMUConfig",
    "FMUError",
    "FMUNode",
    "FMUParticipant",
    "INTERFACES",
    "Interface",
    "LogLine",
    "Model",
    "PROGRAM",
    "SOLVERS",
    "Solver",
    "Variable",
    "build_image",
    "default_step",
    "describe",
    "participant",
    "simulate",
}


def test_fmi_exports_the_intended_names_and_loads_fmpy_on_use() -> None:
    import multicosim.fmi as fmi

    assert set(fmi.__all__) == FMI_EXPECTED
    for name in fmi.__all__:
        assert getattr(fmi, name) is not None, name
    assert issubclass(fmi.FMUError, mcs.NodeError)
    assert fmi.FMUError.__module__ == "multicosim.fmi"
    code = (
        "import sys, multicosim.fmi; "
        "print([m for m in ('fmpy', 'docker', 'mujoco', 'mcap') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


class Goal(mcs.Message):
    """Where to go."""

    x: float


def test_firmware_decorator_keeps_the_functions_name_docstring_and_signature() -> None:
    import inspect
    import pydoc

    def goto(goal: Goal, ctx: mcs.FirmwareContext) -> float:
        """Drive to ``goal.x``; return where the cart stopped."""
        return goal.x

    wrapped = mcs.firmware(msgtype=Goal, period=0.02)(goto)
    assert isinstance(wrapped, mcs.Firmware)
    assert wrapped.__name__ == "goto"
    assert wrapped.__qualname__ == goto.__qualname__
    assert wrapped.__module__ == __name__
    assert wrapped.__doc__ == goto.__doc__
    assert inspect.signature(wrapped) == inspect.signature(goto)
    assert wrapped.__wrapped__ is goto
    # help() shows the function's own docstring, not the generic Firmware text.
    text = pydoc.plain(pydoc.render_doc(wrapped))
    assert "Drive to ``goal.x``" in text
    assert wrapped.name == "goto"
    assert wrapped.period == 0.02


def test_essentials_are_documented_where_help_finds_them() -> None:
    import inspect

    from multicosim import testing
    from multicosim.search.falsify import FalsificationResult

    # The assertion a falsification test ends with, and the topic the cart listens on.
    assert "AssertionError" in str(inspect.getdoc(FalsificationResult.assert_holds))
    assert "assert_holds" in str(inspect.getdoc(FalsificationResult))
    assert "topic ``cmd``" in str(inspect.getdoc(testing.Cart))


def test_the_cart_moves_as_its_documented_topic_commands() -> None:
    from multicosim import testing

    seen: list[float] = []

    class Commander:
        period = 0.01

        def setup(self, ctx: mcs.StepContext) -> None:
            self.state = ctx.subscribe("state", testing.CartState)

        def step(self, ctx: mcs.StepContext) -> None:
            ctx.publish("cmd", testing.Speed(speed=2.0))
            if self.state.latest is not None:
                seen.append(self.state.latest.x)

    simulator = mcs.ProcessSimulator(seed=0)
    simulator.add(mcs.InProcessComponent(Commander, name="commander"))
    simulator.add(mcs.InProcessComponent(testing.Cart, name="cart"))
    with simulator.start() as simulation:
        simulation.advance(1.0)
    assert seen[-1] == pytest.approx(2.0, abs=0.1)  # 2 m/s for about a second
