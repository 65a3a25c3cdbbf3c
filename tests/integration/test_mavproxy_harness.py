"""The MAVProxy harness against a minimal fake fixed-wing, and what MAVProxy sends for each command.

The fake speaks MAVLink 2 (``gcs.adapters.mavlink_wire`` selects it; MAVProxy 1.8.75
always sends MAVLink 2) to MAVProxy's ``udpin`` port from ``udpout``, as sysid 7 with
autopilot ARDUPILOTMEGA so MAVProxy maps ArduPlane mode numbers. Recorded here:

* ``mode GUIDED``: COMMAND_LONG MAV_CMD_DO_SET_MODE (176), param1 1
  (MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), param2 15; never the legacy SET_MODE.
* ``guided LAT LON ALT``: COMMAND_INT MAV_CMD_DO_REPOSITION (192), frame 3
  (MAV_FRAME_GLOBAL_RELATIVE_ALT, MAVProxy's ``flytoframe AboveHome``), param1 -1,
  param2 1 (MAV_DO_REPOSITION_FLAGS_CHANGE_MODE), x/y = ``int(deg * 1e7)`` (truncated,
  so 149.17 gives 1491699999), z metres.
* ``arm throttle``: COMMAND_LONG MAV_CMD_COMPONENT_ARM_DISARM (400), param1 1.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, GCS_SYSID, mavlink, mavutil
from tests.integration.mavproxy_harness import MavProxy
from tests.loopback import LOCALHOST

SYSID = 7
LAT_DEG, LON_DEG = -35.3632621, 149.1652374
ALT_MSL_M, REL_ALT_M = 684.0, 100.0
WAIT_S = 30.0
"""Every wait's deadline; the fake's heartbeat is 1 Hz, so a mode change shows within about 1 s on an idle
machine, and a loaded one gets the rest."""


class FakeFixedWing:
    """Heartbeat, GPS_RAW_INT and VFR_HUD at 1 Hz, GLOBAL_POSITION_INT at 4 Hz, flying east.

    Obeys MAV_CMD_DO_SET_MODE and arming, acknowledges every command, answers a
    parameter list request with one parameter, and records all it receives.
    """

    def __init__(self, port: int, sysid: int = SYSID, mode: str = "LOITER") -> None:
        self.sysid = sysid
        self.custom_mode = ARDUPLANE_MODES[mode]
        self.armed = False
        self.received: list[Any] = []
        self._conn = mavutil.mavlink_connection(f"udpout:{LOCALHOST}:{port}", source_system=sysid,
                                                source_component=1, dialect="ardupilotmega")
        self._heard = threading.Condition()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fake-fixed-wing", daemon=True)

    def __enter__(self) -> FakeFixedWing:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(WAIT_S)
        self._conn.close()

    def wait_for(self, msg_type: str, timeout: float = WAIT_S, **fields: float) -> Any:
        """The first received ``msg_type`` whose ``fields`` have the given values."""
        def match() -> Any:
            return next((m for m in self.received if m.get_type() == msg_type
                         and all(getattr(m, k) == v for k, v in fields.items())), None)

        with self._heard:
            if not self._heard.wait_for(lambda: match() is not None, timeout):
                heard = sorted({m.get_type() for m in self.received})
                raise AssertionError(f"no {msg_type} {fields} within {timeout} s; heard {heard}")
            return match()

    def _run(self) -> None:
        start = next_second = next_quarter = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_second:
                self._send_slow(now - start)
                next_second += 1.0
            if now >= next_quarter:
                self._send_position(now - start)
                next_quarter += 0.25
            msg = self._conn.recv_match(blocking=True, timeout=0.05)
            if msg is not None and msg.get_type() != "BAD_DATA":
                self._obey(msg)

    def _send_slow(self, t: float) -> None:
        mav = self._conn.mav
        base_mode = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
                     | mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
                     | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0))
        mav.heartbeat_send(mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base_mode,
                           self.custom_mode, mavlink.MAV_STATE_ACTIVE)
        mav.gps_raw_int_send(int(t * 1e6), mavlink.GPS_FIX_TYPE_3D_FIX, round(LAT_DEG * 1e7), round(LON_DEG * 1e7),
                             round(ALT_MSL_M * 1e3), 100, 100, 1500, 9000, 12)
        mav.vfr_hud_send(15.0, 15.0, 90, 50, ALT_MSL_M, 0.0)

    def _send_position(self, t: float) -> None:
        self._conn.mav.global_position_int_send(int(t * 1e3), round(LAT_DEG * 1e7), round(LON_DEG * 1e7),
                                                round(ALT_MSL_M * 1e3), round(REL_ALT_M * 1e3), 0, 1500, 0, 9000)

    def _obey(self, msg: Any) -> None:
        mav = self._conn.mav
        kind = msg.get_type()
        if kind in ("COMMAND_LONG", "COMMAND_INT") and msg.target_system == self.sysid:
            if msg.command == mavlink.MAV_CMD_DO_SET_MODE:
                self.custom_mode = int(msg.param2)
            elif msg.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
                self.armed = msg.param1 == 1
            mav.command_ack_send(msg.command, mavlink.MAV_RESULT_ACCEPTED, 0, 0,
                                 msg.get_srcSystem(), msg.get_srcComponent())
        elif kind == "PARAM_REQUEST_LIST" and msg.target_system == self.sysid:
            mav.param_value_send(b"SYSID_THISMAV", float(self.sysid), mavlink.MAV_PARAM_TYPE_REAL32, 1, 0)
        with self._heard:
            self.received.append(msg)
            self._heard.notify_all()


@pytest.fixture
def plane(mavproxy: MavProxy) -> Iterator[FakeFixedWing]:
    with FakeFixedWing(mavproxy.master_port) as fake:
        mavproxy.wait_for_vehicle(SYSID, WAIT_S)
        yield fake


def test_mavproxy_sees_the_vehicle_its_mode_gps_and_position(mavproxy: MavProxy, plane: FakeFixedWing) -> None:
    assert mavproxy.wait_for_vehicle(SYSID, WAIT_S) == 1
    mavproxy.wait_for(rf"online system {SYSID}\b", WAIT_S)
    mavproxy.wait_for_mode("LOITER", WAIT_S)
    assert mavproxy.mode == "LOITER"
    mavproxy.wait_for(rf"GPS lock at {int(ALT_MSL_M)} meters", WAIT_S)

    heartbeat = mavproxy.message("HEARTBEAT", WAIT_S)
    assert (heartbeat["type"], heartbeat["autopilot"], heartbeat["custom_mode"]) == (
        mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, ARDUPLANE_MODES["LOITER"])
    gps = mavproxy.message("GPS_RAW_INT", WAIT_S)
    assert (gps["fix_type"], gps["lat"], gps["lon"]) == (3, round(LAT_DEG * 1e7), round(LON_DEG * 1e7))
    position = mavproxy.message("GLOBAL_POSITION_INT", WAIT_S)
    assert (position["lat"], position["lon"], position["relative_alt"], position["hdg"]) == (
        round(LAT_DEG * 1e7), round(LON_DEG * 1e7), round(REL_ALT_M * 1e3), 9000)

    # MAVProxy asks for the parameters about 2 s after the first heartbeat and again every few
    # seconds until it has them; it needs none of them (nor AUTOPILOT_VERSION) for the above.
    plane.wait_for("PARAM_REQUEST_LIST", target_system=SYSID)
    mavproxy.wait_for(r"Received 1 parameters", WAIT_S)


def test_mode_guided_sends_do_set_mode_and_the_prompt_follows(mavproxy: MavProxy, plane: FakeFixedWing) -> None:
    mavproxy.wait_for_mode("LOITER", WAIT_S)
    mavproxy.command("mode GUIDED", r"Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", WAIT_S)

    command = plane.wait_for("COMMAND_LONG", command=mavlink.MAV_CMD_DO_SET_MODE)
    assert (command.get_srcSystem(), command.target_system, command.target_component) == (GCS_SYSID, SYSID, 1)
    assert command.param1 == mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert command.param2 == ARDUPLANE_MODES["GUIDED"] == 15
    assert command.get_msgbuf()[0] == mavlink.PROTOCOL_MARKER_V2
    mavproxy.wait_for_mode("GUIDED", WAIT_S)
    assert not [m for m in plane.received if m.get_type() == "SET_MODE"]


def test_guided_sends_do_reposition_relative_to_home(mavproxy: MavProxy, plane: FakeFixedWing) -> None:
    lat_deg, lon_deg, alt_m = -35.35, 149.17, 120.0
    mavproxy.command(f"guided {lat_deg} {lon_deg} {alt_m:g}", r"Got COMMAND_ACK: DO_REPOSITION: ACCEPTED", WAIT_S)

    command = plane.wait_for("COMMAND_INT", command=mavlink.MAV_CMD_DO_REPOSITION)
    assert command.frame == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
    assert (command.param1, command.param2) == (-1, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE)
    assert abs(command.x - round(lat_deg * 1e7)) <= 1  # MAVProxy truncates: int(deg * 1e7)
    assert abs(command.y - round(lon_deg * 1e7)) <= 1
    assert command.z == alt_m
    assert (command.target_system, command.target_component) == (SYSID, 1)


def test_arm_throttle_sends_arm_disarm_and_mavproxy_sees_armed(mavproxy: MavProxy, plane: FakeFixedWing) -> None:
    mavproxy.command("arm throttle", r"Got COMMAND_ACK: COMPONENT_ARM_DISARM: ACCEPTED", WAIT_S)

    command = plane.wait_for("COMMAND_LONG", command=mavlink.MAV_CMD_COMPONENT_ARM_DISARM)
    assert (command.param1, command.param2) == (1, 0)
    mavproxy.wait_for(r"\bARMED\b", WAIT_S)


def test_close_stops_mavproxy_and_keeps_its_transcript(tmp_path: Path) -> None:
    proxy = MavProxy(workdir=tmp_path)
    with proxy:
        pid = proxy.pid
        assert pid is not None
        proxy.command("status", r"MAV Errors: 0", WAIT_S)
        proxy.wait_for_mode("MAV", WAIT_S)  # the prompt before any vehicle
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    proxy.close()  # a second close is harmless
    assert "Waiting for heartbeat from" in (tmp_path / "mavproxy.out").read_text()
    assert (tmp_path / "mav.tlog").exists()
