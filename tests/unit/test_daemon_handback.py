"""The daemon gives its vehicles back when no vehicle has seen the target for ``handback_after_lost_s``."""

from __future__ import annotations

import numpy as np

from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from gcs.config.world import build_world
from gcs.core.kinematics import VehicleState
from gcs.core.steering import PlannedPath
from gcs.engine.steps import ReadyStep
from gcs.scenarios import load_scenario

SCENARIO = load_scenario("wang2012_urban")
NS = 1_000_000_000


class RecordingCommander:
    """Stands in for the MAVLink commander: notes whom the daemon lets go of, and why."""

    def __init__(self) -> None:
        self.let_go_of: list[tuple[str, str]] = []

    def let_go(self, vehicle_id: str, why: str) -> None:
        self.let_go_of.append((vehicle_id, why))


def test_vehicles_are_let_go_of_after_the_target_is_lost_for_long_and_steered_again_once_seen() -> None:
    daemon = Daemon(SCENARIO, build_world(SCENARIO), DaemonOptions(
        zenoh=ZenohSettings(listen=(), connect=()), handback_after_lost_s=5.0))  # never opened: no sockets
    commander = daemon.commander = RecordingCommander()
    straight = PlannedPath.from_plan(VehicleState(np.zeros((1, 2)), np.zeros(1), np.full(1, 25.0), np.full(1, 200.0)),
                                     np.zeros(5), 1.0, 0.2)
    daemon.loop.paths = {"uav1": straight}

    def step(k: int, seen: bool) -> None:
        daemon._carry_out(daemon.engine.watch_target(ReadyStep(k, k * NS, ()), seen))

    step(0, True)
    for k in range(1, 5):  # 4 s unseen: still steering
        step(k, False)
    assert commander.let_go_of == [] and "uav1" in daemon.loop.paths
    step(5, False)  # 5 s: handed back
    assert commander.let_go_of == [(v.id, "target lost for 5 s") for v in SCENARIO.vehicles]
    assert daemon.loop.paths == {} and daemon.loop.target_lost and daemon.counters["target_lost"] == 1
    step(6, False)  # once
    assert len(commander.let_go_of) == len(SCENARIO.vehicles)
    step(7, True)
    assert not daemon.loop.target_lost
