"""A daemon warns once, naming both, when the vehicles it hears fly another scenario (loopback Zenoh)."""

from __future__ import annotations

import logging
import threading

from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from gcs.config.fingerprint import scenario_fingerprint
from gcs.config.world import build_world
from gcs.scenarios import load_scenario
from sim_vehicles.run_options import RunOptions
from tests.integration.sim_harness import SCENARIO, running_vehicles, wait_until
from tests.loopback import ANY_PORT_ENDPOINT, daemon_ports

OTHER = load_scenario("downtown_dense")


def test_vehicles_of_another_scenario_are_named_once_beside_the_daemons_own(caplog) -> None:
    daemon = Daemon(OTHER, build_world(OTHER), DaemonOptions(zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,),
                                                                                   connect=())))
    daemon.open()
    endpoint, _ = daemon_ports(daemon)
    thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
    thread.start()
    try:
        with caplog.at_level(logging.WARNING, logger="gcs.engine.ingest"), running_vehicles(RunOptions(
                rate=10.0, seed=1, zenoh=ZenohSettings(connect=(endpoint,)), wait_for_subscriber_s=30.0)):
            # every vehicle announces once a second of its time: wait for several rounds of all three
            wait_until(lambda: daemon.ingest.counters["accepted.scenario"] >= 9, 60, "three announcements each")
    finally:
        daemon.stop()
        thread.join(timeout=15)
    assert not thread.is_alive()
    warnings = [r.getMessage() for r in caplog.records if "flies scenario" in r.getMessage()]
    assert len(warnings) == 1, warnings  # nine announcements or more, one warning
    vehicle = warnings[0].split()[1]
    assert vehicle in {v.id for v in SCENARIO.vehicles}
    assert warnings[0] == (f"vehicle {vehicle} flies scenario wang2012_urban (fingerprint "
                           f"{scenario_fingerprint(SCENARIO)}), but this daemon runs downtown_dense (fingerprint "
                           f"{scenario_fingerprint(OTHER)}): start the daemon and the vehicles with the same "
                           "--scenario")
