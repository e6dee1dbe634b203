"""Traces read without multicosim: the mcap library's reader and Foxglove's published schemas."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema
from mcap.reader import make_reader

DIALECT = "https://json-schema.org/draft/2020-12/schema"


def published_schema(name: str) -> dict[str, Any]:
    """Foxglove's published schema ``foxglove.NAME``, as the files shipped with multicosim."""
    text = resources.files("multicosim.trace").joinpath("foxglove", f"{name}.json").read_text()
    schema: dict[str, Any] = json.loads(text)
    return schema


def read_independently(trace: Path) -> tuple[dict[str, Any], dict[str, list[tuple[int, Any]]]]:
    """Schemas by topic and messages by topic, read with the mcap library's reader."""
    schemas: dict[str, Any] = {}
    messages: dict[str, list[tuple[int, Any]]] = {}
    with open(trace, "rb") as stream:
        reader = make_reader(stream)
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            assert schema is not None
            assert schema.encoding == "jsonschema"
            assert channel.message_encoding == "json"
            schemas[channel.topic] = (schema.name, json.loads(schema.data))
            messages.setdefault(channel.topic, []).append(
                (message.log_time, json.loads(message.data))
            )
    return schemas, messages


def validate_foxglove(
    schemas: dict[str, Any], messages: dict[str, list[tuple[int, Any]]]
) -> tuple[dict[str, str], int]:
    """Check every ``foxglove.*`` channel against Foxglove's published schema (embedded
    unmodified, every message valid, stamped at its log time); the ``foxglove.*`` channels
    (topic -> schema name) and how many messages were validated.
    """
    foxglove = {topic: name for topic, (name, _) in schemas.items() if name.startswith("foxglove.")}
    validated = 0
    for topic, name in foxglove.items():
        published = published_schema(name.removeprefix("foxglove."))
        embedded = dict(schemas[topic][1])
        assert embedded.pop("$schema") == DIALECT
        assert embedded == published, f"{topic}: the schema is not Foxglove's published one"
        validator = jsonschema.Draft202012Validator(published)
        for log_time, data in messages[topic]:
            validator.validate(data)
            if "timestamp" in data:
                stamp = data["timestamp"]
                assert stamp["sec"] * 10**9 + stamp["nsec"] == log_time
            validated += 1
    return foxglove, validated
