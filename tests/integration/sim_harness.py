"""Run simulated vehicles in a background thread and talk to them as a pymavlink ground station."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace

import msgspec

from gcs.adapters.mavlink_wire import GCS_SYSID, mavlink, open_connection
from gcs.config.world import build_world
from gcs.scenarios import load_scenario
from sim_vehicles.run_options import RunOptions
from sim_vehicles.runner import Runner

SCENARIO = load_scenario("wang2012_urban")
"""The default scenario: its vehicles answer as ArduPlane does (``[simulation] autopilot``)."""
WORLD = build_world(SCENARIO)
IDEAL_SCENARIO = msgspec.structs.replace(
    SCENARIO, simulation=msgspec.structs.replace(SCENARIO.simulation, autopilot="ideal"))
"""The default scenario with the ``ideal`` autopilot, which obeys every steering message (carrots too)."""


@contextmanager
def running_vehicles(options: RunOptions, scenario=SCENARIO) -> Iterator[Runner]:
    """The scenario's vehicles (the default one's unless given) flying in a thread; stopped and joined on exit."""
    runner = Runner(scenario, WORLD, options)
    errors: list[BaseException] = []

    def target() -> None:
        try:
            runner.run()
        except BaseException as error:  # surfaced in the test thread below
            errors.append(error)

    thread = threading.Thread(target=target, name="sim-vehicles", daemon=True)
    thread.start()
    try:
        yield runner
    finally:
        runner.stop()
        thread.join(timeout=10)
        assert not thread.is_alive(), "the simulated vehicles did not stop"
        if errors:
            raise errors[0]


class GroundStation:
    """A minimal pymavlink GCS on ``udpin:127.0.0.1:<port>`` (sysid 255); ``port`` 0 (the default) lets the
    system choose it, read back as :attr:`port`."""

    def __init__(self, port: int = 0, signing_key: bytes | None = None) -> None:
        self.conn = open_connection(f"udpin:127.0.0.1:{port}", source_system=GCS_SYSID, source_component=190)
        self.port: int = self.conn.port.getsockname()[1]
        if signing_key is not None:
            self.conn.setup_signing(signing_key, sign_outgoing=True)

    def close(self) -> None:
        self.conn.close()

    def wait(self, msg_type: str, sysid: int | None = None, timeout: float = 30.0,
             condition: Callable[[object], bool] | None = None):
        """The next message of a type (from a sysid, meeting a condition); AssertionError on timeout."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            message = self.conn.recv_match(type=msg_type, blocking=True, timeout=0.1)
            if message is None:
                continue
            if sysid is not None and message.get_srcSystem() != sysid:
                continue
            if condition is None or condition(message):
                return message
        raise AssertionError(f"no {msg_type} from {sysid} meeting the condition within {timeout} s")

    def command_long(self, sysid: int, command: int, *params: float) -> None:
        p = list(params) + [0.0] * (7 - len(params))
        self.conn.mav.command_long_send(sysid, 1, command, 0, *p)

    def command_int(self, sysid: int, command: int, frame: int, params: tuple, x: int = 0, y: int = 0,
                    z: float = 0.0) -> None:
        p = list(params) + [0.0] * (4 - len(params))
        self.conn.mav.command_int_send(sysid, 1, frame, command, 0, 0, *p, x, y, z)

    def ack(self, sysid: int, command: int, timeout: float = 30.0) -> int:
        """Result of the COMMAND_ACK for ``command`` from ``sysid``."""
        return self.wait("COMMAND_ACK", sysid, timeout, lambda m: m.command == command).result

    def set_mode(self, sysid: int, custom_mode: int) -> int:
        self.command_long(sysid, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, custom_mode)
        return self.ack(sysid, mavlink.MAV_CMD_DO_SET_MODE)

    def course_deg(self, sysid: int, timeout: float = 30.0) -> float:
        """Course over the ground from GLOBAL_POSITION_INT's NED velocity, degrees in [0, 360)."""
        message = self.wait("GLOBAL_POSITION_INT", sysid, timeout)
        return math.degrees(math.atan2(message.vy, message.vx)) % 360.0


def angle_error_deg(a: float, b: float) -> float:
    """|a - b| on the circle, degrees."""
    return abs((a - b + 180.0) % 360.0 - 180.0)


def options(port: int | dict[str, int], **changes) -> RunOptions:
    """Every vehicle to ``udpout:127.0.0.1:<port>`` (or each to its own port: ``{vehicle: port}``), no zenoh,
    10x real time."""
    ports = port if isinstance(port, dict) else {v.id: port for v in SCENARIO.vehicles}
    base = RunOptions(rate=10.0, seed=1, mavlink={v: f"udpout:127.0.0.1:{p}" for v, p in ports.items()})
    return replace(base, **changes)


def wait_until(condition: Callable[[], object], timeout: float, what: str) -> None:
    """Poll ``condition`` every 50 ms until it is truthy; AssertionError naming ``what`` after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")
