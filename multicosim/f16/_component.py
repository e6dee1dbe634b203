"""The F-16 as a component ([`Aircraft`][multicosim.f16._component.Aircraft]) and the node it starts
([`AircraftNode`][multicosim.f16._component.AircraftNode]).

The component runs the participant where its placement says (this process, a local process,
a container with AeroBench's directory mounted read-only at the same path); the node keeps
what the participant published, from the simulation's own traffic, whatever the placement.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import TYPE_CHECKING, Any

from ..core.clock import Delivery
from ..core.errors import ConfigurationError
from ..core.geo import quaternion_from_euler
from ..core.interfaces import Component, Node
from ..core.messages import decode
from ..local import LocalEnvironment, required_images
from ..local.waits import DEFAULT_START_TIMEOUT, check_timeout
from ..placement import ParticipantProgram, Placement, as_placement
from ._config import F16Config
from ._messages import F16State, Flight
from ._participant import PROGRAM

if TYPE_CHECKING:
    from ..trace import TraceOptions

__all__ = ["FEET", "Aircraft", "AircraftNode"]

FEET = 0.3048
"""Metres per foot: traces draw paths and poses in metres."""


@dataclasses.dataclass(frozen=True)
class Aircraft:
    """The F-16 and its GCAS autopilot as a component: flies ``config`` where ``placement``
    says (a registered name or a [`Placement`][multicosim.placement.Placement]).

    In a container, AeroBench's code directory is mounted read-only at the same path, so that
    the configuration holds there as it does here.

    Raises:
        ConfigurationError: naming the field (``config``, ``name``, ``placement``,
            ``start_timeout``) with an invalid value.
    """

    config: F16Config
    name: str = "f16"
    placement: str | Placement = "in-process"
    start_timeout: float = DEFAULT_START_TIMEOUT

    def __post_init__(self) -> None:
        if not isinstance(self.config, F16Config):
            raise ConfigurationError("config", self.config, "a multicosim.f16.F16Config")
        if not isinstance(self.name, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", self.name):
            raise ConfigurationError(
                "name", self.name, "a component name of letters, digits, '_', '.' and '-'"
            )
        as_placement(self.placement)
        check_timeout("start_timeout", self.start_timeout)

    def program(self) -> ParticipantProgram:
        """The participant program its placement runs."""
        code = self.config.directory
        return ParticipantProgram(
            PROGRAM,
            self.config,
            self.name,
            start_timeout=self.start_timeout,
            mounts={code: code},
        )

    def _placed(self) -> Component[Any, Node]:
        return as_placement(self.placement).participant(self.program())

    def required_images(self) -> tuple[str, ...]:
        """The images its placement needs (the runtime image in a container, else none)."""
        return tuple(required_images(self._placed()))

    def start(self, environment: LocalEnvironment) -> AircraftNode:
        """Start the F-16 where it is placed; it flies from the current instant."""
        kept: list[Delivery] = []
        topic = self.config.topic

        def keep(delivery: Delivery) -> None:
            if delivery.topic == topic:
                kept.append(delivery)

        scheduler = environment.scheduler
        scheduler.taps.append(keep)
        try:
            node = self._placed().start(environment)
        except BaseException:
            scheduler.taps.remove(keep)
            raise
        placement = as_placement(self.placement).name
        return AircraftNode(self.name, placement, node, self.config, kept)


class AircraftNode:
    """A flying F-16: the node where it runs and the states it published.

    [`flight`][multicosim.f16._component.AircraftNode.flight] gives them as a
    [`Flight`][multicosim.f16._component.Flight];
    [`trace_options`][multicosim.f16._component.AircraftNode.trace_options] tells a trace recorder
    its channels. ``node`` is the underlying in-process, process or container node.
    """

    def __init__(
        self, name: str, placement: str, node: Node, config: F16Config, kept: list[Delivery]
    ) -> None:
        self.name = name
        self.placement = placement
        """The name of the placement it runs in."""
        self.node = node
        self.config = config
        self._kept = kept

    def parts(self) -> list[Node]:
        """The node that runs it."""
        return [self.node]

    def flight(self, fidelity: str = "") -> Flight:
        """Every state published so far, as a flight (``fidelity``: the level it flies at)."""
        samples = [_state(d) for d in self._kept]
        return Flight(samples=samples, fidelity=fidelity)

    def trace_options(self) -> TraceOptions:
        """Its channels: the state typed, its path and pose (ENU metres), plots of altitude
        and attitude."""
        from ..trace import TraceOptions, local_path, message_path, pose_in_frame

        topic = self.config.topic
        plots = [
            ("F-16 altitude (ft)", [message_path(topic, "altitude")]),
            ("F-16 attitude (rad)", [message_path(topic, n) for n in ("roll", "pitch", "yaw")]),
            ("F-16 airspeed (ft/s)", [message_path(topic, "airspeed")]),
        ]
        return TraceOptions(
            types={topic: F16State},
            converters=(pose_in_frame(topic, _pose), local_path(topic, _enu, label="truth")),
            plots=plots,
        )

    def stop(self) -> None:
        """Stop it where it runs; what it published stays."""
        self.node.stop()

    def __repr__(self) -> str:
        return f"AircraftNode({self.name!r}, placement={self.placement!r})"


def _state(delivery: Delivery) -> F16State:
    if type(delivery.obj) is F16State:
        return delivery.obj
    return decode(delivery.data, F16State, what="the F-16's state")


def _enu(message: Any) -> tuple[float, float, float]:
    return message["east"] * FEET, message["north"] * FEET, message["altitude"] * FEET


def _pose(message: Any) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    # AeroBench's Euler angles are of the body (forward, right, down) in north-east-down; in
    # east-north-up with the body forward, left, up, roll stays, pitch and heading turn over.
    orientation = quaternion_from_euler(
        message["roll"], -message["pitch"], math.pi / 2 - message["yaw"]
    )
    return _enu(message), orientation
