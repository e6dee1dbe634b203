"""The MAVLink parameter protocol, as PX4 v1.15.4 serves it.

Every PX4 parameter (``params``), indexed by name order; integers travel bytewise in
PARAM_VALUE's float as PX4 sends them, and a PARAM_SET is read by the parameter's own type
(as PX4 reads it, whatever type the sender claims). Unknown names get no answer at all,
which is what PX4 does. A full list goes out a few dozen values per step, as a link would
pace it.
"""

from __future__ import annotations

from typing import Any

from .params import decode_value, encode_value
from .state import State

__all__ = ["ParamServer"]

PARAMS_PER_STEP = 40


class ParamServer(State):
    """The parameter protocol (a part of ``Autopilot``)."""

    _param_queue: list[str]
    _param_index: dict[str, int]

    def _param_value(self, name: str) -> None:
        params = self.params
        ptype = params.type_of(name)
        index = self._param_index
        if not index:
            index.update((n, i) for i, n in enumerate(params.names))
        self._send(
            self._d.MAVLink_param_value_message(
                name.encode(), encode_value(params[name], ptype), ptype, len(index), index[name]
            )
        )

    def _param_tick(self) -> None:
        queue = self._param_queue
        for name in queue[:PARAMS_PER_STEP]:
            self._param_value(name)
        del queue[:PARAMS_PER_STEP]

    def _on_param_request_list(self, m: Any) -> None:
        self._param_queue = list(self.params.names)

    def _on_param_request_read(self, m: Any) -> None:
        names = self.params.names
        name = _param_name(m.param_id)
        if m.param_index >= 0:
            if m.param_index < len(names):
                self._param_value(names[m.param_index])
        elif name in self.params:
            self._param_value(name)

    def _on_param_set(self, m: Any) -> None:
        name = _param_name(m.param_id)
        if name not in self.params:
            return  # PX4 does not answer for names it does not have
        # PX4 takes any value over MAVLink, its metadata's range notwithstanding.
        self.params.assign(name, decode_value(m.param_value, self.params.type_of(name)))
        self._param_value(name)  # the echo tells the sender the value now in effect


def _param_name(raw: Any) -> str:
    text = raw.decode(errors="replace") if isinstance(raw, bytes) else str(raw)
    return text.split("\0", 1)[0]
