"""A pass-through participant: forwards every message of one topic to another, unchanged.

Used by ``bench_scaling.py`` to chain 1..8 components between the rover world and its
controller (what sensor injectors add, without their models). Run in-process as
``Relay(RelayConfig(...))`` or as a process:
``python -m multicosim participant bench._relay:relay --config '{"source": ..., "target": ...}'``.
"""

from __future__ import annotations

import msgspec

import multicosim as mcs
from multicosim.rover import Position


class RelayConfig(msgspec.Struct, frozen=True):
    """Where to read, where to publish, how often."""

    source: str
    target: str
    period: float = 0.025


class Relay:
    """Publishes on ``target`` every Position received on ``source``, in order."""

    def __init__(self, config: RelayConfig) -> None:
        self.config = config
        self.period = config.period

    def setup(self, ctx: mcs.StepContext) -> None:
        """Subscribe to the source topic."""
        self.source = ctx.subscribe(self.config.source, Position)

    def step(self, ctx: mcs.StepContext) -> None:
        """Forward what arrived since the last step."""
        for message in self.source.messages:
            ctx.publish(self.config.target, message)


def relay(config: RelayConfig) -> Relay:
    """The participant factory for ``multicosim participant``."""
    return Relay(config)
