"""The daemon in a thread through one whole flight of the simulated vehicles (a thread too), on loopback."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from sim_vehicles.run_options import RunOptions
from sim_vehicles.runner import Runner
from tests.integration.sim_harness import wait_until
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, daemon_ports

__all__ = ["daemon_through_a_flight"]


@contextmanager
def daemon_through_a_flight(scenario, world, recording: Path, *, seed: int, duration_s: float, rate: float,
                            epoch_ns: int) -> Iterator[tuple[Daemon, str]]:
    """The daemon (recording to ``recording``) and its Zenoh endpoint, once the vehicles have flown
    ``duration_s`` at ``rate`` times real time and the daemon has fused all but their last two steps;
    the vehicles and the daemon are stopped on exit, the daemon's thread joined."""
    daemon = Daemon(scenario, world, DaemonOptions(
        zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()), record=recording,
        mavlink={v.id: ANY_UDP for v in scenario.vehicles}))
    daemon.open()
    endpoint, ports = daemon_ports(daemon)
    thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
    thread.start()
    runner = Runner(scenario, world, RunOptions(
        rate=rate, seed=seed, duration_s=duration_s, epoch_ns=epoch_ns, wait_for_subscriber_s=5,
        mavlink={v.id: f"udpout:127.0.0.1:{ports[v.id]}" for v in scenario.vehicles},
        zenoh=ZenohSettings(connect=(endpoint,))))
    vehicles = threading.Thread(target=runner.run, name="sim-vehicles", daemon=True)
    try:
        vehicles.start()
        vehicles.join(timeout=duration_s / rate * 10 + 60)  # a backstop for a stalled simulation
        assert not vehicles.is_alive(), "the simulated vehicles did not finish"
        wait_until(lambda: len(daemon.records) >= duration_s - 2, 60, "the last steps to be fused")
        yield daemon, endpoint
    finally:
        runner.stop()
        daemon.stop()
        thread.join(timeout=15)
        vehicles.join(timeout=10)
    assert not thread.is_alive(), "the daemon did not stop"
