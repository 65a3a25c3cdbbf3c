"""MAVLink 2 signing on the command links: a signed vehicle obeys only commands signed with its key.

The simulated vehicles are signed with the key MAVProxy derives from a
passphrase (``signing key PASS``: sha256 of it). Commands that reach a vehicle
unsigned or signed with another key are dropped by its MAVLink layer before
its autopilot sees them. Every vehicle's link is one UDP socket, so a command
sent earlier arrives earlier: once a later, well-signed command has been
obeyed, the earlier ones' absence from what the autopilot handled shows they
were dropped, without waiting on a clock.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, mavlink, signing_key_from_passphrase
from sim_vehicles.runner import Runner
from tests.integration.mavproxy_harness import DEFAULT_MODULES, MavProxy
from tests.integration.sim_harness import GroundStation, options, running_vehicles


PASSPHRASE = "correct-horse-battery"  # MAVProxy's `signing key` takes one word
KEY = signing_key_from_passphrase(PASSPHRASE)
GUIDED, LOITER, CIRCLE = ARDUPLANE_MODES["GUIDED"], ARDUPLANE_MODES["LOITER"], ARDUPLANE_MODES["CIRCLE"]
WAIT_S = 30.0


def _record_mode_commands(runner: Runner, vehicle: str) -> list[int]:
    """The custom modes of every mode command vehicle's autopilot handles from now on."""
    seen: list[int] = []
    autopilot = runner.autopilots[vehicle]
    handle = autopilot.handle

    def recording(message, now_s, state):
        if message.get_type() == "COMMAND_LONG" and message.command == mavlink.MAV_CMD_DO_SET_MODE:
            seen.append(int(message.param2))
        elif message.get_type() == "SET_MODE":
            seen.append(int(message.custom_mode))
        return handle(message, now_s, state)

    autopilot.handle = recording
    return seen


def _wait_for_autopilots(runner: Runner) -> None:
    import time

    deadline = time.monotonic() + WAIT_S
    while len(runner.autopilots) < 3:
        assert time.monotonic() < deadline, "the simulated vehicles did not start"
        time.sleep(0.02)


def test_a_signed_vehicle_ignores_unsigned_and_wrongly_signed_commands() -> None:
    station = GroundStation()
    try:
        with running_vehicles(options(station.port, signing_key=KEY)) as runner:
            station.wait("HEARTBEAT", 1)
            _wait_for_autopilots(runner)
            handled = _record_mode_commands(runner, "uav1")
            station.command_long(1, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)
            station.conn.setup_signing(signing_key_from_passphrase("not-the-passphrase"), sign_outgoing=True)
            station.command_long(1, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)
            station.conn.setup_signing(KEY, sign_outgoing=True)
            assert station.set_mode(1, CIRCLE) == mavlink.MAV_RESULT_ACCEPTED
            assert handled == [CIRCLE]  # the unsigned and the wrongly signed GUIDED never reached the autopilot
            assert runner.autopilots["uav1"].mode == CIRCLE
            assert runner.endpoints.counters()["bad_data"] >= 2
    finally:
        station.close()


@pytest.fixture
def signing_mavproxy(tmp_path) -> Iterator[MavProxy]:
    with MavProxy(workdir=tmp_path / "mavproxy", modules=(*DEFAULT_MODULES, "signing")) as proxy:
        yield proxy


def test_through_mavproxy_only_signing_key_with_the_vehicles_passphrase_commands_them(signing_mavproxy) -> None:
    proxy = signing_mavproxy
    with running_vehicles(options(proxy.master_port, rate=5.0, signing_key=KEY)) as runner:
        proxy.wait_for(r"online system 1\b", WAIT_S)  # signed messages are read by a MAVProxy without a key
        proxy.wait_for_mode("LOITER", WAIT_S)
        _wait_for_autopilots(runner)
        handled = _record_mode_commands(runner, "uav1")

        proxy.send("mode GUIDED")  # unsigned
        proxy.command("signing key not-the-passphrase", r"Setup signing key", WAIT_S)
        proxy.send("mode GUIDED")  # signed with another key
        proxy.command(f"signing key {PASSPHRASE}", r"Setup signing key", WAIT_S)
        proxy.command("mode CIRCLE", r"Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", WAIT_S)
        proxy.wait_for_mode("CIRCLE", WAIT_S)
        assert handled == [CIRCLE]
        assert {v: ap.mode for v, ap in runner.autopilots.items()} == {"uav1": CIRCLE, "uav2": LOITER,
                                                                        "uav3": LOITER}
