"""A run's fingerprint: one hash of every sample it routed, and where two runs first differ.

Two runs of one seed are the same run when they routed the same messages at the same
simulated times: the fingerprint hashes each message's MessagePack encoding (what crosses
every process and container boundary, so the placements compare as they are) with its topic
and time. Messages of one instant are put in a canonical order (topic, then encoding): which
of two components published first within an instant is the transport's business, not the
run's. A run that differs is located at its first differing sample: time, topic, field and
both values.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import msgspec

from ._recorder import Recorder, to_builtins

__all__ = ["Difference", "Fingerprint", "fingerprint"]

_Sample = tuple[int, str, bytes]  # time (ns), topic, MessagePack encoding


@dataclasses.dataclass(frozen=True)
class Difference:
    """Where two runs first differ: a sample's simulated time, topic and field, both values.

    ``field`` is a path into the message (``position[2]``, ``reached[0].index``); empty when
    one run has a sample the other has not (then the missing side is None).
    """

    time: float
    topic: str
    field: str
    first: object
    second: object
    simulation: int = 0
    """Which of the test's simulations (in the order they started) differs."""

    def __str__(self) -> str:
        where = f"t={self.time:.9g} s, topic {self.topic!r}"
        if self.simulation:
            where = f"simulation {self.simulation + 1}, {where}"
        if not self.field:
            first, second = _presence(self.first), _presence(self.second)
            return f"{where}: {first} in the first run, {second} in the other"
        return f"{where}, field {self.field!r}: {self.first!r} != {self.second!r}"


def _presence(value: object) -> str:
    return "no such sample" if value is None else f"{value!r}"


class Fingerprint:
    """Every sample a test's simulations routed, in canonical order, and their hash.

    ``digest`` (hexadecimal BLAKE2b, 128 bits) is equal for two runs exactly when their
    samples are; [`first_difference`][multicosim.trace._fingerprint.Fingerprint.first_difference]
    names where they part. ``deterministic`` is False when real firmware flew (its own threads: runs
    of one seed may part).
    """

    def __init__(
        self,
        runs: Sequence[Sequence[_Sample]],
        types: Sequence[Mapping[str, Any]] = (),
        *,
        deterministic: bool = True,
    ) -> None:
        self.deterministic = deterministic
        self._runs = [sorted(samples) for samples in runs]
        self._types = list(types) or [{} for _ in runs]
        h = hashlib.blake2b(digest_size=16)
        for index, samples in enumerate(self._runs):
            h.update(b"simulation %d\0" % index)
            for time_ns, topic, data in samples:
                h.update(b"%d\0%s\0%d\0" % (time_ns, topic.encode(), len(data)))
                h.update(data)
        self.digest = h.hexdigest()

    @property
    def samples(self) -> int:
        """How many samples (routed messages) it covers."""
        return sum(len(samples) for samples in self._runs)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Fingerprint) and other.digest == self.digest

    def __hash__(self) -> int:
        return hash(self.digest)

    def __repr__(self) -> str:
        return f"Fingerprint({self.digest}, {self.samples} samples)"

    def first_difference(self, other: Fingerprint) -> Difference | None:
        """The first sample (in simulated time) where ``other`` differs; None when equal."""
        if other.digest == self.digest:
            return None
        for index in range(max(len(self._runs), len(other._runs))):
            mine = self._runs[index] if index < len(self._runs) else []
            theirs = other._runs[index] if index < len(other._runs) else []
            types = self._types[index] if index < len(self._types) else {}
            found = _first_difference(mine, theirs, types)
            if found is not None:
                return dataclasses.replace(found, simulation=index)
        return None  # pragma: no cover - equal samples hash equal


def _first_difference(
    mine: Sequence[_Sample], theirs: Sequence[_Sample], types: Mapping[str, Any]
) -> Difference | None:
    for position in range(max(len(mine), len(theirs))):
        a = mine[position] if position < len(mine) else None
        b = theirs[position] if position < len(theirs) else None
        if a == b:
            continue
        if a is None or b is None or a[:2] != b[:2]:
            # One run has a sample the other has not: name the earlier of the two.
            mine_first = b is None or (a is not None and a[:2] < b[:2])
            first = a if mine_first else b
            assert first is not None  # both None would have been equal
            decoded = _decode(first, types)
            return Difference(
                first[0] / 1e9,
                first[1],
                "",
                decoded if mine_first else None,
                None if mine_first else decoded,
            )
        field, va, vb = next(_fields(_decode(a, types), _decode(b, types)), ("", a[2], b[2]))
        return Difference(a[0] / 1e9, a[1], field, va, vb)
    return None


def _decode(sample: _Sample, types: Mapping[str, Any]) -> object:
    tp = types.get(sample[1])
    try:
        message = (
            msgspec.msgpack.decode(sample[2], type=tp)
            if tp is not None
            else msgspec.msgpack.decode(sample[2])
        )
    except msgspec.DecodeError:
        return sample[2]
    return to_builtins(message)


def _fields(a: object, b: object, path: str = "") -> Iterator[tuple[str, object, object]]:
    """The leaves where ``a`` and ``b`` differ, depth first, as (path, a's value, b's value)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in list(a) + [k for k in b if k not in a]:
            yield from _fields(a.get(key), b.get(key), f"{path}.{key}" if path else str(key))
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            yield from _fields(x, y, f"{path}[{i}]")
    elif type(a) is not type(b) or (a != b and not (a != a and b != b)):  # NaN equals NaN here
        yield path, a, b


def fingerprint(recorders: Sequence[Recorder]) -> Fingerprint:
    """The fingerprint of what ``recorders`` recorded (a test's simulations, in start order)."""
    return Fingerprint(
        [[(d.time_ns, d.topic, d.data) for d in r.deliveries] for r in recorders],
        [r.types for r in recorders],
        deterministic=all(r.options.deterministic for r in recorders),
    )
