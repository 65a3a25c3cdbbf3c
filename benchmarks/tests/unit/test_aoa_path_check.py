"""``gcs-bench aoa``'s own check of the flown paths (eq. 36-39, by its own formulas) catches what it is meant to."""

from __future__ import annotations

import math

import numpy as np

from benchmarks.aoa import AoaScenario, path_violations


def test_bench_path_check_counts_each_kind_of_violation() -> None:
    scenario = AoaScenario(steps=3)
    start = np.array([0.0, 0.0])
    xy = np.array([[[0.0, 0.0], [1000.0, 0.0]], [[40.0, 0.0], [1040.0, 0.0]], [[80.0, 0.0], [1080.0, 0.0]]])
    target = np.tile([5000.0, 0.0], (3, 1))
    ok = path_violations(scenario, xy, np.zeros((3, 2)), start, target)
    assert ok == {"turn": 0, "detection": 0, "too_close": 0, "too_far": 0}
    sharp = np.array([[0.0, 0.0], [math.radians(4.5), 0.0], [0.0, 0.0]])  # 4.5 deg at step 1 (the last is not flown)
    assert path_violations(scenario, xy, sharp, start, target)["turn"] == 1
    assert path_violations(scenario, xy, np.zeros((3, 2)), np.array([math.radians(-4.1), 0.0]), target)["turn"] == 1
    close = xy.copy()
    close[2, 1] = [180.0, 0.0]
    far_target = np.tile([30_000.0, 0.0], (3, 1))
    assert path_violations(scenario, close, np.zeros((3, 2)), start, far_target) == {
        "turn": 0, "detection": 4, "too_close": 1, "too_far": 0}

