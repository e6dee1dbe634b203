"""Our fast MAVLink paths agree with pymavlink byte for byte and field for field."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from multicosim.mavlink.dialect import decode_frames, dialect, new_link, pack_scalar, remember

i32 = st.integers(-(2**31), 2**31 - 1)
u32 = st.integers(0, 2**32 - 1)
i16 = st.integers(-(2**15), 2**15 - 1)
f32 = st.floats(-1e6, 1e6, width=32)


@given(st.tuples(u32, i32, i32, i32, i32, i16, i16, i16, st.integers(0, 65535)))
def test_pack_scalar_is_pymavlinks_pack(values: tuple[int, ...]) -> None:
    d = dialect()
    ours, theirs = new_link(1, 1), new_link(1, 1)
    cls = d.MAVLink_global_position_int_message
    assert pack_scalar(ours, cls, *values) == bytes(cls(*values).pack(theirs))
    assert ours.seq == 1


@given(u32, st.tuples(f32, f32, f32, f32, f32, f32))
def test_decode_frames_matches_pymavlink(t: int, floats: tuple[float, ...]) -> None:
    d = dialect()
    tx = new_link(7, 3)
    msgs = [
        d.MAVLink_attitude_message(t, *floats),
        d.MAVLink_heartbeat_message(2, 12, 129, 0x04040000, 4, 3),
        d.MAVLink_sys_status_message(1, 2, 3, 4, 5, -1, 100, 0, 0, 0, 0, 0, 0, 0, 0, 0),
        d.MAVLink_gps_raw_int_message(t, 3, 1, 2, 3, 4, 5, 6, 7, 12, 0, 0, 0, 0, 0, 0),
        d.MAVLink_statustext_message(6, b"hello", 0, 0),
        d.MAVLink_param_value_message(b"NAV_ACC_RAD", 2.0, 9, 16, 3),
    ]
    data = b"".join(bytes(m.pack(tx)) for m in msgs)
    rx = new_link(0, 0)
    reference = new_link(0, 0).parse_buffer(data)
    ours = decode_frames(rx, data)
    assert [m.get_type() for m in ours] == [m.get_type() for m in reference]
    for a, b in zip(ours, reference, strict=True):
        assert a.get_srcSystem() == 7
        assert a.get_srcComponent() == 3
        for field in b.get_fieldnames():
            x, y = getattr(a, field), getattr(b, field)
            assert x == y or (isinstance(x, float) and math.isnan(x) and math.isnan(y))


def test_decode_frames_survives_garbage() -> None:
    d = dialect()
    good = bytes(d.MAVLink_heartbeat_message(2, 12, 0, 0, 3, 3).pack(new_link(1, 1)))
    corrupt = bytearray(good)
    corrupt[-1] ^= 0xFF  # bad CRC: dropped, as pymavlink drops it
    # Trailing garbage goes to pymavlink's stream parser (which reports BAD_DATA).
    decoded = decode_frames(new_link(0, 0), good + b"\x00\x01")
    assert decoded[0].get_type() == "HEARTBEAT"
    assert all(m.get_type() != "HEARTBEAT" for m in decode_frames(new_link(0, 0), bytes(corrupt)))


def test_a_packet_of_one_remembered_frame_is_parsed() -> None:
    # A one-frame packet is its own frame: the message left to parse is parsed, not looked up.
    d = dialect()
    frame = bytes(d.MAVLink_heartbeat_message(2, 12, 0, 0, 3, 3).pack(new_link(1, 1)))
    remember(frame, [(frame, None)])
    (decoded,) = decode_frames(new_link(0, 0), frame)
    assert decoded.get_type() == "HEARTBEAT"
    assert decoded.get_srcSystem() == 1
