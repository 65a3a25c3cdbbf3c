"""A MAVLink link that goes silent for 10 s: the daemon stops commanding it, and resumes when it returns.

The simulated vehicles reach the daemon through a UDP relay on 127.0.0.1
(:class:`sim_vehicles.radio_link.UdpRelay`, the soak's) that the test can mute (both
directions dropped), like a radio out of range, while their Zenoh reports
keep flowing.
"""

from __future__ import annotations

import threading
import time
from contextlib import ExitStack

from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from sim_vehicles.radio_link import UdpRelay
from tests.integration.sim_harness import SCENARIO, WORLD, options, running_vehicles
from tests.loopback import ANY_PORT_ENDPOINT

SILENCE_S = 10.0
ROSTER = tuple(v.id for v in SCENARIO.vehicles)


def _wait(condition, timeout_s: float, what: str) -> float:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return time.monotonic()
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def to_vehicles(counters) -> int:
    """Messages the commander sent to vehicles: everything but its own GCS heartbeats."""
    return counters["sent"] - counters["gcs_heartbeats"]


def test_commands_stop_while_the_link_is_silent_and_resume_when_it_returns() -> None:
    with ExitStack() as stack:
        relay = UdpRelay()  # the daemon sends to its ground port, the vehicles to its port
        stack.callback(relay.close)
        daemon = Daemon(SCENARIO, WORLD, DaemonOptions(zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()),
                                                       mavlink={v: f"udpout:127.0.0.1:{relay.ground_port}"
                                                                for v in ROSTER},
                                                       planner="orbit", plan_runner="inline"))
        daemon.open()
        (endpoint,) = daemon.zenoh_listening
        thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
        thread.start()
        stack.callback(thread.join, 20)
        stack.callback(daemon.stop)
        runner = stack.enter_context(running_vehicles(options(
            relay.port, rate=2.0, zenoh=ZenohSettings(connect=(endpoint,)), epoch_ns=10**15,
            wait_for_subscriber_s=5)))

        def commands() -> int:  # what uav1's autopilot received (its autopilots appear once the runner is open)
            autopilot = runner.autopilots.get("uav1")
            return 0 if autopilot is None else autopilot.counters["COMMAND_INT"]

        _wait(lambda: commands() >= 5 and daemon.counters["decisions"] >= 3, 60, "commands before the silence")
        relay.muted = True
        muted_at = time.monotonic()
        _wait(lambda: daemon.commander.counters()["link_lost"] >= len(ROSTER), 60, "the daemon to see the links lost")
        at_mute = commands()  # seconds after the mute: a datagram the relay was forwarding as it muted has landed
        decisions = daemon.counters["decisions"]
        sent_after_loss = to_vehicles(daemon.commander.counters())
        # the rest of the 10 s of silence, and however long a slow machine takes to plan two more steps
        _wait(lambda: time.monotonic() >= muted_at + SILENCE_S and daemon.counters["decisions"] >= decisions + 2,
              120, "planning to go on from the Zenoh reports through the silence")
        assert commands() == at_mute  # nothing got through
        assert to_vehicles(daemon.commander.counters()) == sent_after_loss  # nor was sent to a lost link
        assert daemon.registry.alive("uav1", time.monotonic())  # still alive on Zenoh: planned for

        relay.muted = False
        _wait(lambda: daemon.commander.counters()["link_up"] >= 2 * len(ROSTER), 60, "the links to come back")
        _wait(lambda: commands() >= at_mute + 5, 60, "commands to resume")
        counters = daemon.commander.counters()
    assert relay.dropped > 0 and not thread.is_alive()
    assert counters["link_lost"] == len(ROSTER) and counters["link_up"] == 2 * len(ROSTER)
    assert not any(name.startswith("errors.") for name in daemon.counters), daemon.counters
