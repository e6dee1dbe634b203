"""MCAP files: writing channels of JSON messages, reading a trace back, its metadata record."""

from __future__ import annotations

import dataclasses
import importlib.metadata
import json
import platform
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import msgspec

from ..core.deps import require
from ..core.errors import TraceError
from ..core.files import replacing
from ._schemas import Schema

__all__ = [
    "METADATA_NAME",
    "ChannelInfo",
    "TraceData",
    "TraceMessage",
    "package_versions",
    "read_trace",
    "write_mcap",
]

METADATA_NAME = "multicosim"
# Distributions whose versions go into a trace's metadata (what made the run what it is).
VERSIONED = (
    "multicosim",
    "msgspec",
    "numpy",
    "pyzmq",
    "mujoco",
    "mcap",
    "rtamt",
    "hypothesis",
    "psy-taliro",
    "docker",
    "pymavlink",
)

# (log time in ns, channel, schema, JSON payload), in time order.
Row = tuple[int, str, Schema, bytes]


def write_mcap(path: Path, rows: Iterable[Row], metadata: Mapping[str, object]) -> dict[str, str]:
    """Write ``rows`` and the metadata record to ``path``; return topic -> schema name.

    Written whole or not at all: a failure (a full disk) leaves no partial file behind.
    """
    mcap_writer = require("mcap.writer", "trace")
    channels: dict[str, int] = {}
    names: dict[str, str] = {}
    schemas: dict[tuple[str, str], int] = {}
    sequence: dict[str, int] = {}
    try:
        with replacing(path) as temporary, open(temporary, "wb") as stream:
            writer = mcap_writer.Writer(stream)
            writer.start(profile="", library=f"multicosim {_version('multicosim')}")
            for time_ns, topic, schema, payload in rows:
                cid = channels.get(topic)
                if cid is None:
                    text = json.dumps(schema.schema, sort_keys=True)
                    sid = schemas.get((schema.name, text))
                    if sid is None:
                        sid = writer.register_schema(schema.name, "jsonschema", text.encode())
                        schemas[(schema.name, text)] = sid
                    cid = channels[topic] = writer.register_channel(topic, "json", sid)
                    names[topic] = schema.name
                seq = sequence[topic] = sequence.get(topic, 0) + 1
                writer.add_message(
                    cid, log_time=time_ns, data=payload, publish_time=time_ns, sequence=seq
                )
            writer.add_metadata(METADATA_NAME, metadata_record(metadata))
            writer.finish()
    except OSError as exc:
        raise TraceError(f"could not write the trace {str(path)!r}: {exc}") from exc
    return names


def _version(distribution: str) -> str:
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def package_versions() -> dict[str, str]:
    """Python and the versions of the packages that shape a run."""
    versions = {"python": platform.python_version()}
    versions.update({name: _version(name) for name in VERSIONED})
    return versions


def metadata_record(record: Mapping[str, object]) -> dict[str, str]:
    """MCAP metadata holds strings: keep strings as they are, encode the rest as JSON."""
    out = {"versions": json.dumps(package_versions(), sort_keys=True)}
    for key, value in record.items():
        if value is None:
            continue
        if isinstance(value, str):
            out[key] = value
        else:
            out[key] = msgspec.json.encode(value, order="sorted").decode()
    return dict(sorted(out.items()))


@dataclasses.dataclass(frozen=True)
class ChannelInfo:
    """A channel of a trace: topic, schema name and schema, encoding, message count."""

    topic: str
    schema_name: str
    schema: Mapping[str, Any]
    message_encoding: str
    count: int


@dataclasses.dataclass(frozen=True)
class TraceMessage:
    """One message of a trace, decoded from JSON."""

    topic: str
    log_time: int
    data: Any

    @property
    def time(self) -> float:
        """Simulated time in seconds."""
        return self.log_time / 1e9


@dataclasses.dataclass(frozen=True)
class TraceData:
    """A trace read back: channels by topic, messages in time order, metadata records."""

    channels: Mapping[str, ChannelInfo]
    messages: Sequence[TraceMessage]
    metadata: Mapping[str, Mapping[str, str]]

    def topic(self, name: str) -> list[TraceMessage]:
        """The messages of topic ``name`` in time order."""
        return [m for m in self.messages if m.topic == name]

    @property
    def info(self) -> Mapping[str, str]:
        """The multicosim metadata record (empty if absent)."""
        return self.metadata.get(METADATA_NAME, {})


def read_trace(path: str | Path) -> TraceData:
    """Read a trace with the mcap reader; raise TraceError if it is not a readable MCAP file."""
    mcap_reader = require("mcap.reader", "trace")
    channels: dict[str, ChannelInfo] = {}
    counts: dict[str, int] = {}
    messages: list[TraceMessage] = []
    metadata: dict[str, dict[str, str]] = {}
    try:
        stream = open(path, "rb")  # noqa: SIM115 - closed below, apart from parse errors
    except OSError as exc:
        raise TraceError(f"could not read the trace {str(path)!r}: {exc}") from exc
    try:
        with stream:
            reader = mcap_reader.make_reader(stream)
            for schema, channel, message in reader.iter_messages(log_time_order=True):
                if channel.topic not in channels:
                    channels[channel.topic] = ChannelInfo(
                        channel.topic,
                        schema.name if schema is not None else "",
                        json.loads(schema.data) if schema is not None and schema.data else {},
                        channel.message_encoding,
                        0,
                    )
                counts[channel.topic] = counts.get(channel.topic, 0) + 1
                data = (
                    json.loads(message.data)
                    if channel.message_encoding == "json"
                    else bytes(message.data)
                )
                messages.append(TraceMessage(channel.topic, message.log_time, data))
            for record in reader.iter_metadata():
                metadata[record.name] = dict(record.metadata)
    except Exception as exc:  # the mcap reader raises assorted errors on corrupt input
        raise TraceError(f"{str(path)!r} is not a readable MCAP trace: {exc}") from exc
    channels = {t: dataclasses.replace(c, count=counts[t]) for t, c in channels.items()}
    return TraceData(channels, messages, metadata)
