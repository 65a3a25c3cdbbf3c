"""The daemon's takeover guard and hand-back against simulated vehicles on loopback, and what `gcs status` says.

The simulated vehicles fly armed at 200-220 m (the default scenario), in LOITER until a ground station
switches them.
"""

from __future__ import annotations

import threading
from contextlib import ExitStack

import msgspec

from gcs.adapters.mavlink_takeover import Takeover
from gcs.adapters.mavlink_wire import ARDUPLANE_MODES
from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from gcs.daemon.cli import query_status
from tests.integration.sim_harness import SCENARIO, WORLD, options, running_vehicles, wait_until
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, daemon_ports

RATE = 5.0
EPOCH_NS = 2_000_000_000_000
GUIDED, LOITER, RTL = ARDUPLANE_MODES["GUIDED"], ARDUPLANE_MODES["LOITER"], ARDUPLANE_MODES["RTL"]
VEHICLES = [v.id for v in SCENARIO.vehicles]


def modes(runner) -> dict[str, int | None]:
    """Each vehicle's autopilot mode (None until the runner has opened its MAVLink, or for one it does not fly)."""
    return {v: getattr(runner.autopilots.get(v), "mode", None) for v in VEHICLES}


def start_daemon(stack: ExitStack, takeover: Takeover) -> tuple[Daemon, str, int]:
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(
        zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()), mavlink=dict.fromkeys(VEHICLES, ANY_UDP),
        planner="orbit", plan_runner="inline", takeover=takeover))
    daemon.open()
    endpoint, port = daemon_ports(daemon)
    thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
    thread.start()
    stack.callback(lambda: (daemon.stop(), thread.join(timeout=15)))
    return daemon, endpoint, port


def test_vehicles_below_the_takeover_altitude_are_commanded_but_never_switched() -> None:
    with ExitStack() as stack:
        daemon, endpoint, port = start_daemon(stack, Takeover(min_altitude_m=500.0))
        runner = stack.enter_context(running_vehicles(options(
            port, rate=RATE, zenoh=ZenohSettings(connect=(endpoint,)), epoch_ns=EPOCH_NS, wait_for_subscriber_s=5)))
        wait_until(lambda: daemon.counters["decisions"] >= 10, 60, "10 plans")
        status = query_status(ZenohSettings(connect=(endpoint,)), "gcs", 5.0)
        flown = modes(runner)
        counters = {v: daemon.commander.link(v).counters.copy() for v in VEHICLES}
    assert flown == dict.fromkeys(VEHICLES, LOITER)  # never switched: 200-220 m is below 500 m
    for vehicle_id in VEHICLES:
        assert counters[vehicle_id]["mode_requests"] == 0 and counters[vehicle_id]["takeover_held"] == 1
        assert counters[vehicle_id]["heading_commands"] == 0  # GUIDED_CHANGE_* only in GUIDED
    assert status is not None
    assert [(v.link, v.heartbeat, v.liveliness, v.control) for v in status.vehicles] == \
        [("ok", "ok", "ok", "waiting: below 500 m")] * len(VEHICLES)


def test_vehicles_taken_over_are_given_back_in_rtl_when_the_daemon_stops() -> None:
    with ExitStack() as stack:
        daemon_stack = stack.enter_context(ExitStack())  # closed early below; at the latest with the test
        daemon, endpoint, port = start_daemon(daemon_stack, Takeover(min_altitude_m=100.0, handback="RTL"))
        runner = stack.enter_context(running_vehicles(options(
            port, rate=RATE, zenoh=ZenohSettings(connect=(endpoint,)), epoch_ns=EPOCH_NS, wait_for_subscriber_s=5)))
        wait_until(lambda: modes(runner) == dict.fromkeys(VEHICLES, GUIDED), 60, "every vehicle in GUIDED")
        # the daemon learns the mode from each vehicle's next HEARTBEAT, up to a second of vehicle time later
        wait_until(lambda: all(daemon.commander.control(v, 0.0) == "daemon" for v in VEHICLES), 60,
                   "the daemon to hear every vehicle in GUIDED")
        status = query_status(ZenohSettings(connect=(endpoint,)), "gcs", 5.0)
        daemon_stack.close()  # the daemon stops: its loop returns, close() hands the vehicles back
        wait_until(lambda: modes(runner) == dict.fromkeys(VEHICLES, RTL), 60, "every vehicle in RTL")
        counters = daemon.commander.counters()
    assert status is not None and [v.control for v in status.vehicles] == ["daemon"] * len(VEHICLES)
    assert counters["handbacks"] == len(VEHICLES) and counters["ack_accepted"] >= len(VEHICLES)
    assert {daemon.commander.control(v, 0.0) for v in VEHICLES} == {"handed back: the daemon stopped"}


ON_GROUND = msgspec.structs.replace(SCENARIO, simulation=msgspec.structs.replace(
    SCENARIO.simulation, start_on_ground=True))


def test_vehicles_on_the_ground_wait_for_the_pilot_or_are_taken_off_with_takeoff() -> None:
    with ExitStack() as stack:
        waiting, endpoint, port = start_daemon(stack, Takeover(min_altitude_m=40.0))
        runner = stack.enter_context(running_vehicles(options(
            port, rate=RATE, zenoh=ZenohSettings(connect=(endpoint,)), epoch_ns=EPOCH_NS, wait_for_subscriber_s=5,
            only=("uav1",)), ON_GROUND))
        wait_until(lambda: waiting.commander.control("uav1", 0.0) == "waiting: disarmed", 60, "uav1 held back")
        sent = waiting.commander.link("uav1").counters.copy()
        altitude = runner.scene.vehicles["uav1"].state.position_enu_m[2]
    assert sent["mode_requests"] == 0 and sent["arm_requests"] == 0 and altitude == 0.0

    with ExitStack() as stack:
        daemon, endpoint, port = start_daemon(stack, Takeover(min_altitude_m=40.0, takeoff=True))
        runner = stack.enter_context(running_vehicles(options(
            port, rate=RATE, zenoh=ZenohSettings(connect=(endpoint,)), epoch_ns=EPOCH_NS, wait_for_subscriber_s=5,
            only=("uav1",)), ON_GROUND))
        wait_until(lambda: daemon.commander.control("uav1", 0.0) == "waiting: taking off", 60, "uav1 taking off")
        wait_until(lambda: modes(runner)["uav1"] == GUIDED, 60, "uav1 in GUIDED once above 40 m")
        altitude = runner.scene.vehicles["uav1"].state.position_enu_m[2]
        sent = daemon.commander.link("uav1").counters.copy()
    assert altitude >= 40.0
    assert sent["arm_requests"] >= 1 and sent["mode_requests"] >= 2  # TAKEOFF, then GUIDED
    assert sent["commands_rejected"] == 0
