"""Every FMI type through topics: what a component publishes is what the FMU gets, and what
the FMU outputs is what other components receive (the Feedthrough FMUs pass inputs on)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import fmpy
import numpy as np
import pytest

import multicosim as mcs
from multicosim import fmi

FMI3_VALUES: dict[str, Any] = {
    "Float32_continuous_input": 0.25,
    "Float64_continuous_input": -0.5,
    "Int8_input": -128,
    "UInt8_input": 255,
    "Int16_input": -32768,
    "UInt16_input": 65535,
    "Int32_input": -(2**31),
    "UInt32_input": 2**32 - 1,
    "Int64_input": -(2**63),
    "UInt64_input": 2**64 - 1,
    "Boolean_input": True,
    "String_input": "multicosim",
    "Binary_input": b"\x00\xff",
    "Enumeration_input": 2,
}
FMI2_VALUES: dict[str, Any] = {
    "Float64_continuous_input": -0.5,
    "Int32_input": -(2**31),
    "Boolean_input": True,
    "String_input": "multicosim",
    "Enumeration_input": 2,
}


class Source:
    """Publishes fixed values on ``in/NAME`` every step."""

    period = 0.1

    def __init__(self, values: dict[str, Any]) -> None:
        self.values = values

    def setup(self, ctx: mcs.StepContext) -> None:
        """Nothing to subscribe to."""

    def step(self, ctx: mcs.StepContext) -> None:
        """Publish every value."""
        for name, value in self.values.items():
            ctx.publish(f"in/{name}", value)


class Sink:
    """Keeps the latest value of every ``out/NAME`` topic."""

    period = 0.1

    def __init__(self, names: list[str]) -> None:
        self.names = names
        self.subs: dict[str, mcs.Subscription[Any]] = {}

    def setup(self, ctx: mcs.StepContext) -> None:
        """Subscribe to the outputs, decoded as plain data."""
        self.subs = {n: ctx.subscribe(f"out/{n}", object) for n in self.names}

    def step(self, ctx: mcs.StepContext) -> None:
        """Values are read at the end."""


@pytest.mark.parametrize(
    ("version", "values"), [("fmi2", FMI2_VALUES), ("fmi3", FMI3_VALUES)], ids=["fmi2", "fmi3"]
)
@pytest.mark.parametrize("where", ["in-process", "process"])
def test_values_of_every_type_pass_through_the_fmu(
    reference_fmus: Path, version: str, values: dict[str, Any], where: str
) -> None:
    outputs = {name: name.replace("input", "output") for name in values}
    component = fmi.FMU(
        reference_fmus / version / "Feedthrough.fmu",
        name="feedthrough",
        period=0.1,
        inputs={name: f"in/{name}" for name in values},
        outputs={out: f"out/{name}" for name, out in outputs.items()},
        placement=where,
    )
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(lambda: Source(values), "source"))
    node_id = simulator.add(component)
    sink = simulator.add(mcs.InProcessComponent(lambda: Sink(list(values)), "sink"))
    with simulator.start() as simulation:
        simulation.advance(0.35)
        received = {n: s.latest for n, s in simulation.get(sink).participant.subs.items()}
        record = simulation.get(node_id).records()[-1]
    for name, value in values.items():
        assert received[name] == value, name
        assert getattr(record, outputs[name]) == value, name


def test_a_message_of_the_wrong_type_names_the_topic(reference_fmus: Path) -> None:
    component = fmi.FMU(
        reference_fmus / "fmi3" / "Feedthrough.fmu",
        period=0.1,
        inputs={"UInt8_input": "in/byte"},
    )
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(lambda: Source({"byte": 256}), "source"))
    simulator.add(component)
    with simulator.start() as simulation, pytest.raises(mcs.TransportError) as info:
        simulation.advance(0.15)
    assert "'in/byte'" in str(info.value)
    assert "<= 255" in str(info.value)


def test_arrays_travel_as_flat_lists(reference_fmus: Path) -> None:
    # StateSpace with A = B = C = 0 and D = I: y = u.
    zero = np.zeros((3, 3))
    component = fmi.FMU(
        reference_fmus / "fmi3" / "StateSpace.fmu",
        name="gain",
        period=1.0,
        parameters={"A": zero, "B": zero, "C": zero, "D": np.eye(3)},
        inputs={"u": "in/u"},
        outputs={"y": "out/y"},
    )
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(lambda: Source({"u": [1.5, -2.0, 3.25]}), "source"))
    node_id = simulator.add(component)
    with simulator.start() as simulation:
        simulation.advance(2.5)
        result = simulation.get(node_id).result()
    assert result.dtype["y"].shape == (3,)
    np.testing.assert_array_equal(result["y"][-1], [1.5, -2.0, 3.25])


SCALAR_PLANT = {"m": 1, "n": 1, "r": 1, "A": [[-1.0]], "B": [[1.0]], "C": [[1.0]], "D": [[0]]}


def test_structural_parameters_resize_the_arrays(statespace: Path) -> None:
    # A scalar plant x' = -x + u, y = x: the sizes m, n, r set in configuration mode.
    component = fmi.FMU(
        statespace,
        name="plant",
        period=1.0,  # StateSpace declares a fixed internal step of 1 s
        parameters=SCALAR_PLANT,
        start_values={"u": [1.0]},
        record=("x",),
    )
    with pytest.raises(mcs.ConfigurationError, match=r"(?s)parameters\['A'\]=.* 1 values"):
        component.replace(parameters={**SCALAR_PLANT, "A": np.eye(3)})
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(component)
    with simulator.start() as simulation:
        simulation.advance(3.5)
        result = simulation.get(node_id).result()
    assert result.dtype["y"].shape == (1,)
    # Its C code integrates with forward Euler at 1 ms steps: x(3) = 1 - 0.999 ** 3000.
    assert result["time"][-1] == 3.0
    assert result["y"][-1][0] == pytest.approx(1 - 0.999**3000, rel=1e-9)
    assert result["x"][-1][0] == result["y"][-1][0]


def test_an_fmu_refusing_a_value_is_an_error_with_its_log(reference_fmus: Path) -> None:
    # The published StateSpace rejects any structural parameter (see statespace_fixed).
    component = fmi.FMU(
        reference_fmus / "fmi3" / "StateSpace.fmu", period=1.0, parameters=SCALAR_PLANT
    )
    simulator = mcs.ProcessSimulator()
    simulator.add(component)
    with pytest.raises(fmi.FMUError) as info:
        simulator.start()
    error = info.value
    assert (error.name, error.function, error.status, error.time) == (
        "StateSpace",
        "fmi3SetUInt64",
        "Error",
        0.0,
    )
    assert "Expected nValues >= 2 but was 1." in error.log_tail
    # The FMU's own reason ends the message, not only its log.
    assert error.fmu_reason == "Expected nValues >= 2 but was 1."
    assert (
        str(error)
        .splitlines()[0]
        .endswith("returned Error at t=0 s: Expected nValues >= 2 but was 1.")
    )
    assert isinstance(error, mcs.NodeError)


def test_the_result_has_fmpys_columns_for_every_type(reference_fmus: Path) -> None:
    path = reference_fmus / "fmi3" / "Feedthrough.fmu"
    ours = fmi.simulate(path)
    reference = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation")
    assert ours.dtype == reference.dtype
    for column in reference.dtype.names or ():
        np.testing.assert_array_equal(ours[column], reference[column])
