"""The tracker with bearing-only sensors: zuo2021's ML start and VG-UKF in place of the DUIF."""

from __future__ import annotations

import numpy as np

from gcs.core.tracker import Detection, fuse
from gcs.scenarios import load_scenario
from gcs.tracking import tracker_config
from sim_vehicles.truth.sensor import TargetSensor

SCENARIO = load_scenario("zuo2021_aoa")
S = 1_000_000_000


def test_bearing_only_scenario_fuses_with_ml_start_and_vgukf() -> None:
    config = tracker_config(SCENARIO, world=None, planner="ga_k5")
    assert config.bearing_filter is not None and config.sensors[0].components == ("azimuth",)
    truth = TargetSensor.from_config(SCENARIO.sensor)
    rng = np.random.default_rng(8)
    target = np.array([10000.0, 5000.0, 0.0])
    vehicles = np.array([[v.start_enu_m[0], v.start_enu_m[1], v.altitude_m] for v in SCENARIO.vehicles])

    def scan(k: int, count: int) -> list[Detection]:
        moved = vehicles + np.array([40.0 * k, 0.0, 0.0])  # flying east, toward the target
        observed = truth.observe(target, moved[:count], None, rng)
        return [Detection(i, moved[i], observed.values[i]) for i in range(count)]

    assert fuse(config, None, 0, scan(0, 1)) is None  # one bearing fixes no position
    estimate = fuse(config, None, 0, scan(0, 3))
    first_error = np.hypot(*(estimate.mean[:2] - target[:2]))
    for k in range(1, 60):
        estimate = fuse(config, estimate, k * S, scan(k, 3))
    assert estimate.stamp_ns == 59 * S
    error = np.hypot(*(estimate.mean[:2] - target[:2]))
    assert error < 0.5 * first_error and error < 1500.0
    std = np.sqrt(np.linalg.eigvalsh(estimate.cov[:2, :2]).max())
    assert error < 4.0 * std  # the covariance is not wildly overconfident
