"""The daemon's MAVLink decoding, fuzzed: random bytes and absurd field values never crash it.

Whatever a vehicle (or anybody on its link) sends, pymavlink's parser and
:func:`update_from_message` must leave the link's position and heading finite
or unknown, and :func:`due_actions` must still encode what it sends.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.adapters.mavlink_commands import SendMemory, due_actions
from gcs.adapters.mavlink_link import HeadingCommand, VehicleLink, update_from_message
from gcs.adapters.mavlink_wire import mavlink
from gcs.core.geometry import LocalFrame

FRAME = LocalFrame(28.22, 112.99, 50.0)
INT32 = st.integers(-(2**31), 2**31 - 1)
ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True, width=32)


def _heartbeat(draw):
    return mavlink.MAVLink_heartbeat_message(draw(st.integers(0, 255)), draw(st.integers(0, 255)),
                                             draw(st.integers(0, 255)), draw(st.integers(0, 2**32 - 1)),
                                             draw(st.integers(0, 255)), 3)


def _position(draw):
    return mavlink.MAVLink_global_position_int_message(
        draw(st.integers(0, 2**32 - 1)), draw(INT32), draw(INT32), draw(INT32), draw(INT32),
        draw(st.integers(-(2**15), 2**15 - 1)), draw(st.integers(-(2**15), 2**15 - 1)),
        draw(st.integers(-(2**15), 2**15 - 1)), draw(st.integers(0, 2**16 - 1)))


def _attitude(draw):
    return mavlink.MAVLink_attitude_message(draw(st.integers(0, 2**32 - 1)), *[draw(ANY_FLOAT) for _ in range(6)])


@st.composite
def wire(draw) -> bytes:
    """A byte stream: well-formed messages with any field values, mixed with garbage and cut at random."""
    encoder = mavlink.MAVLink(None, srcSystem=draw(st.integers(1, 3)), srcComponent=1)
    chunks = []
    for _ in range(draw(st.integers(1, 8))):
        kind = draw(st.sampled_from(["heartbeat", "position", "attitude", "garbage"]))
        if kind == "garbage":
            chunks.append(draw(st.binary(max_size=40)))
            continue
        message = {"heartbeat": _heartbeat, "position": _position, "attitude": _attitude}[kind](draw)
        packed = bytearray(message.pack(encoder))
        if draw(st.booleans()) and len(packed) > 1:  # flip one byte: a corrupt packet
            index = draw(st.integers(0, len(packed) - 1))
            packed[index] ^= draw(st.integers(1, 255))
        chunks.append(bytes(packed))
    return b"".join(chunks)


@settings(max_examples=300, deadline=None)
@given(wire())
def test_any_bytes_leave_the_link_finite_and_the_commands_encodable(data: bytes) -> None:
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True  # as pymavlink connections parse: bad bytes become BAD_DATA
    link = VehicleLink("uav1", 1, command=HeadingCommand(0.3, 200.0, 25.0))
    memory = SendMemory()
    sender = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    for now, byte in enumerate(data):
        try:
            message = parser.parse_char(bytes([byte]))
        except mavlink.MAVError:
            continue  # the connection's recv_msg raises this; the commander counts it (receive_errors)
        if message is None or message.get_type() == "BAD_DATA":
            continue
        update_from_message(link, message, float(now), FRAME)
        assert link.position_enu_m is None or np.all(np.isfinite(link.position_enu_m))
        assert link.velocity_enu_mps is None or np.all(np.isfinite(link.velocity_enu_mps))
        assert link.heading_enu_rad is None or math.isfinite(link.heading_enu_rad)
        actions, memory = due_actions(FRAME, link, memory, float(now), max_turn_rate_rad_s=0.2, carrot_period_s=0.25,
                                      link_timeout_s=5.0)
        for action in actions:
            action.encode(sender, link.sysid).pack(sender)


def test_absurd_telemetry_is_ignored_and_counted_by_the_caller() -> None:
    link = VehicleLink("uav1", 1)
    nan_yaw = mavlink.MAVLink_attitude_message(0, 0.0, 0.0, float("nan"), 0.0, 0.0, 0.0)
    assert update_from_message(link, nan_yaw, 0.0, FRAME) == "bad_telemetry" and link.heading_enu_rad is None
    off_globe = mavlink.MAVLink_global_position_int_message(0, 2**31 - 1, 0, 0, 0, 0, 0, 0, 65535)
    assert update_from_message(link, off_globe, 0.0, FRAME) == "bad_telemetry" and link.position_enu_m is None
    no_fix = mavlink.MAVLink_global_position_int_message(0, 0, 0, 0, 0, 0, 0, 0, 65535)
    assert update_from_message(link, no_fix, 0.5, FRAME) == "no_fix" and link.position_enu_m is None
    good = mavlink.MAVLink_global_position_int_message(0, 282200000, 1129900000, 250000, 200000, 100, 0, 0, 9000)
    assert update_from_message(link, good, 1.0, FRAME) is None
    assert np.allclose(link.position_enu_m, [0.0, 0.0, 200.0], atol=1e-6)
