"""A MAVLink link that goes silent for 10 s: the daemon stops commanding it, and resumes when it returns.

The simulated vehicles reach the daemon through a UDP relay on 127.0.0.1 that
the test can mute (both directions dropped), like a radio out of range, while
their Zenoh reports keep flowing.
"""

from __future__ import annotations

import socket
import threading
import time
from contextlib import ExitStack

from gcs.adapters.zenoh_session import ZenohSettings
from gcs.app import Daemon, DaemonOptions
from tests.integration.sim_harness import SCENARIO, WORLD, options, running_vehicles
from tests.loopback import LOCALHOST, free_tcp_port, free_udp_port

SILENCE_S = 10.0
ROSTER = tuple(v.id for v in SCENARIO.vehicles)


class Relay:
    """Forwards UDP datagrams between one vehicle side and the daemon's port; ``muted`` drops them all."""

    def __init__(self, daemon_port: int) -> None:
        self.daemon = (LOCALHOST, daemon_port)
        self.outer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # the vehicles send here
        self.outer.bind((LOCALHOST, 0))
        self.inner = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # and this talks to the daemon
        self.inner.bind((LOCALHOST, 0))
        for sock in (self.outer, self.inner):
            sock.settimeout(0.05)
        self.port = self.outer.getsockname()[1]
        self.vehicles: tuple[str, int] | None = None
        self.muted = False
        self.dropped = 0
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._pump, args=(self.outer, True), daemon=True),
                         threading.Thread(target=self._pump, args=(self.inner, False), daemon=True)]
        for thread in self._threads:
            thread.start()

    def _pump(self, sock: socket.socket, from_vehicles: bool) -> None:
        while not self._stop.is_set():
            try:
                data, address = sock.recvfrom(65536)
            except (TimeoutError, socket.timeout):
                continue
            except OSError:
                return
            if from_vehicles:
                self.vehicles = address
            if self.muted:
                self.dropped += 1
                continue
            if from_vehicles:
                self.inner.sendto(data, self.daemon)
            elif self.vehicles is not None:
                self.outer.sendto(data, self.vehicles)

    def close(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=5)
        self.outer.close()
        self.inner.close()


def _wait(condition, timeout_s: float, what: str) -> float:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return time.monotonic()
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def test_commands_stop_while_the_link_is_silent_and_resume_when_it_returns() -> None:
    endpoint, port = f"tcp/127.0.0.1:{free_tcp_port()}", free_udp_port()
    with ExitStack() as stack:
        relay = Relay(port)
        stack.callback(relay.close)
        daemon = Daemon(SCENARIO, WORLD, DaemonOptions(zenoh=ZenohSettings(listen=(endpoint,), connect=()),
                                                       mavlink={v: f"udpin:127.0.0.1:{port}" for v in ROSTER},
                                                       planner="orbit", planner_mode="inline"))
        thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
        thread.start()
        stack.callback(thread.join, 20)
        stack.callback(daemon.stop)
        runner = stack.enter_context(running_vehicles(options(
            relay.port, rate=2.0, zenoh=ZenohSettings(connect=(endpoint,)), epoch_ns=10**15,
            wait_for_subscriber_s=5)))

        def carrots() -> int:  # what uav1's autopilot received (its autopilots appear once the runner is open)
            autopilot = runner.autopilots.get("uav1")
            return 0 if autopilot is None else autopilot.counters["SET_POSITION_TARGET_GLOBAL_INT"]

        _wait(lambda: carrots() >= 5 and daemon.counters["decisions"] >= 3, 60, "commands before the silence")
        relay.muted = True
        muted_at = time.monotonic()
        at_mute = carrots()
        _wait(lambda: daemon.commander.counters()["link_lost"] >= len(ROSTER), 15, "the daemon to see the links lost")
        decisions = daemon.counters["decisions"]
        sent_after_loss = daemon.commander.counters()["carrots"]
        time.sleep(max(0.0, muted_at + SILENCE_S - time.monotonic()))  # the rest of the 10 s of silence
        assert carrots() == at_mute  # nothing got through
        assert daemon.commander.counters()["carrots"] == sent_after_loss  # nor was sent to a lost link
        assert daemon.counters["decisions"] > decisions  # planning went on from the Zenoh reports
        assert daemon.registry.alive("uav1", time.monotonic())  # still alive on Zenoh: planned for

        relay.muted = False
        _wait(lambda: daemon.commander.counters()["link_up"] >= 2 * len(ROSTER), 15, "the links to come back")
        _wait(lambda: carrots() >= at_mute + 5, 15, "commands to resume")
        counters = daemon.commander.counters()
    assert relay.dropped > 0 and not thread.is_alive()
    assert counters["link_lost"] == len(ROSTER) and counters["link_up"] == 2 * len(ROSTER)
    assert not any(name.startswith("errors.") for name in daemon.counters), daemon.counters
