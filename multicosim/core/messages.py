"""Typed messages and their wire encoding.

Messages are msgspec Structs (or anything msgspec encodes: dataclasses, dicts, numbers).
They travel as MessagePack and are validated against the receiver's declared type on
receipt, so nothing executable ever crosses a socket (no pickle).
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any, TypeVar, cast

import msgspec

from .errors import MessageTypeError, TransportError

__all__ = ["Message", "decode", "encode", "json_schema", "type_name"]

T = TypeVar("T")

if TYPE_CHECKING:
    # The message and reply types of a firmware default to Any where a component does not
    # declare them (PEP 696: typing has it from Python 3.13, type checkers from
    # typing_extensions, which is needed only while type checking).
    import typing_extensions

    MsgT = typing_extensions.TypeVar("MsgT", default=Any)
    ReplyT = typing_extensions.TypeVar("ReplyT", default=Any)
else:
    MsgT = TypeVar("MsgT")
    ReplyT = TypeVar("ReplyT")

if TYPE_CHECKING:
    from typing_extensions import dataclass_transform

    # msgspec passes ``frozen`` on to subclasses; tell the type checker so.
    @dataclass_transform(frozen_default=True)
    class _MessageBase(msgspec.Struct, frozen=True): ...
else:
    _MessageBase = msgspec.Struct


class Message(_MessageBase, frozen=True):
    """Base for message types: a frozen msgspec Struct.

    Subclass it and annotate fields:

    ```python
    class Mission(mcs.Message):
        speed: float
    ```

    Messages are immutable because one message object may reach several in-process
    subscribers.
    """


_encoder = msgspec.msgpack.Encoder()


def encode(msg: object) -> bytes:
    """Encode ``msg`` as MessagePack; raises MessageTypeError if it cannot be encoded."""
    try:
        return _encoder.encode(msg)
    except (TypeError, msgspec.EncodeError) as exc:
        raise MessageTypeError(
            "msg", msg, "a msgspec Struct, dataclass or plain data (no arbitrary objects)"
        ) from exc


@functools.cache
def _decoder(tp: Any) -> msgspec.msgpack.Decoder[Any]:
    return msgspec.msgpack.Decoder(tp)


def decode(data: bytes, tp: type[T], *, what: str = "message") -> T:
    """Decode ``data`` as ``tp``, validating it; raises TransportError naming ``what``."""
    try:
        decoder: msgspec.msgpack.Decoder[T] = _decoder(cast(Any, tp))
        return decoder.decode(data)
    except msgspec.ValidationError as exc:
        raise TransportError(f"{what} is not a valid {type_name(tp)}: {exc}") from exc
    except msgspec.DecodeError as exc:
        raise TransportError(f"{what} could not be decoded: {exc}") from exc


def type_name(tp: Any) -> str:
    """A stable, readable name for a message type (its ``__qualname__``)."""
    return str(getattr(tp, "__qualname__", None) or getattr(tp, "__name__", None) or tp)


def json_schema(tp: Any) -> dict[str, Any]:
    """The JSON schema of message type ``tp`` (used for trace channels)."""
    return msgspec.json.schema(tp)
