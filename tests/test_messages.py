"""Typed messages: MessagePack on the wire, validated against the receiver's type."""

from __future__ import annotations

import pickle

import msgspec
import pytest

import multicosim as mcs
from multicosim.core.messages import decode, encode, json_schema, type_name


class Point(mcs.Message):
    x: float
    y: float
    label: str = ""


class Other(mcs.Message):
    speed: int


def test_round_trip() -> None:
    p = Point(x=1.5, y=-2.0, label="a")
    assert decode(encode(p), Point) == p


def test_validation_on_receipt_names_the_type_and_field() -> None:
    bad = encode({"x": "not a number", "y": 1.0})
    with pytest.raises(mcs.TransportError, match=r"not a valid Point.*\$\.x"):
        decode(bad, Point, what="message on topic 'pos'")


def test_missing_field_is_rejected() -> None:
    with pytest.raises(mcs.TransportError, match="missing required field `speed`"):
        decode(encode(Point(x=0, y=0)), Other)


def test_garbage_is_a_transport_error() -> None:
    with pytest.raises(mcs.TransportError, match="could not be decoded"):
        decode(b"\xc1\xc1", Point)


def test_arbitrary_objects_cannot_be_sent() -> None:
    class Secret:
        pass

    with pytest.raises(mcs.MessageTypeError, match="msgspec Struct"):
        encode(Secret())


def test_pickle_payloads_are_not_accepted() -> None:
    # A pickle is not MessagePack of the expected shape: it is rejected, never executed.
    with pytest.raises(mcs.TransportError):
        decode(pickle.dumps(Point(x=1, y=2)), Point)


def test_messages_are_frozen() -> None:
    p = Point(x=1, y=2)
    with pytest.raises(AttributeError):
        p.x = 3  # type: ignore[misc]
    assert hash(p) == hash(Point(x=1, y=2))


def test_json_schema_and_type_name() -> None:
    schema = json_schema(Point)
    assert schema["$defs"]["Point"]["required"] == ["x", "y"]
    assert type_name(Point) == "Point"
    assert isinstance(msgspec.json.encode(schema), bytes)
