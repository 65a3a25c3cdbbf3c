"""Stone Soup peers (benchmarks.stonesoup_peer) on a small seeded scene, scored with our GOSPA.

Three constant-velocity ground targets, two vehicles circling above them with
range/azimuth/elevation sensors, Pd 0.9 and Poisson clutter
(:func:`sim_vehicles.truth.detections.scan`). Both peers must end with three
confirmed tracks and a mean GOSPA over the last scans well below that of an empty
track set, ``(c^p / 2 * N)^(1/p)`` for alpha = 2 (computed here, not with the metric).
"""

from __future__ import annotations

import builtins
import importlib
import sys

import numpy as np
import pytest

from benchmarks.stonesoup_peer import PeerConfig, ground_measurement, gnn_tracker, jpda_tracker, run_peer
from gcs.core.metrics import gospa
from gcs.core.models.sensor import SensorModel
from gcs.core.tracker import Detection
from sim_vehicles.truth.detections import scan

SENSOR = SensorModel.range_bearing(5.0, 0.01, 0.02)
SCANS, STEP_S, CLUTTER, RANGE_M, ALT_M = 40, 1.0, 2.0, 1500.0, 300.0
C, P = 50.0, 2.0


def _scene(seed: int):
    rng = np.random.default_rng(seed)
    start = np.array([[0.0, 0.0], [250.0, 150.0], [-150.0, 300.0]])
    velocity = np.array([[8.0, 2.0], [-5.0, 6.0], [3.0, -7.0]])
    truths, scans = [], []
    for k in range(SCANS):
        t = k * STEP_S
        xy = start + velocity * t
        angle = 0.05 * t + np.array([0.0, np.pi])
        vehicles = np.column_stack([400.0 * np.cos(angle), 400.0 * np.sin(angle), np.full(2, ALT_M)])
        sc = scan(xy, vehicles, SENSOR, pd=0.9, clutter_rate=CLUTTER, max_range_m=RANGE_M, rng=rng)
        scans.append((int(t * 1e9), dict(enumerate(sc.detections)), SENSOR))
        truths.append(xy)
    return truths, scans


CONFIG = PeerConfig(vehicles=2, pd=0.9, clutter_rate=CLUTTER, max_range_m=RANGE_M, sensor_height_m=ALT_M)


@pytest.mark.parametrize("make", [gnn_tracker, jpda_tracker], ids=["gnn", "jpda"])
def test_peer_tracks_the_scene(make):
    truths, scans = _scene(seed=2025)
    run = run_peer(make(CONFIG), scans)
    assert len(run.tracks) == SCANS and len(run.seconds) == SCANS and run.stamps_ns[1] == int(STEP_S * 1e9)
    assert len(run.tracks[-1]) == 3
    empty = (C**P / 2.0 * 3) ** (1.0 / P)  # every truth missed, alpha = 2
    last = [gospa(np.array([[x, y] for _, x, y in tracks]).reshape(-1, 2), truth, C, P).distance
            for tracks, truth in zip(run.tracks[-10:], truths[-10:])]
    assert np.mean(last) < 0.3 * empty
    # the tracks keep their ids over the last scans: the same three ids throughout
    assert len({tid for tracks in run.tracks[-10:] for tid, _, _ in tracks}) == 3


def test_ground_measurement_recovers_the_horizontal_range():
    vehicle = np.array([10.0, -20.0, 300.0])
    target = np.array([410.0, 280.0])
    dx, dy = target - vehicle[:2]
    h = np.hypot(dx, dy)
    values = np.array([np.hypot(h, 300.0), np.arctan2(dy, dx), np.arctan2(-300.0, h)])
    azimuth, horizontal, az_var, h_var = ground_measurement(Detection(0, vehicle, values), SENSOR)
    assert azimuth == pytest.approx(np.arctan2(dy, dx)) and horizontal == pytest.approx(h)
    assert az_var == pytest.approx(0.01**2)
    range_only_var = (5.0 * np.hypot(h, 300.0) / h) ** 2
    assert h_var < range_only_var  # the elevation adds information
    assert h_var > range_only_var * 0.5
    with pytest.raises(ValueError):
        ground_measurement(Detection(0, vehicle, values[1:2]), SensorModel.bearing_only(0.01))
    # zuo2021 eq. (2): beyond the reference range every variance grows as (rho / rho0)^2
    far = SensorModel.range_bearing(5.0, 0.01, 0.02, distance_dependent=True, reference_range_m=250.0)
    scale = (np.hypot(h, 300.0) / 250.0) ** 2
    _, h_far, az_far, h_var_far = ground_measurement(Detection(0, vehicle, values), far)
    assert h_far == pytest.approx(h) and az_far == pytest.approx(0.01**2 * scale)
    assert h_var_far == pytest.approx(h_var * scale)


def test_missing_stone_soup_names_the_extra(monkeypatch):
    real_import = builtins.__import__

    def no_stonesoup(name, *args, **kwargs):
        if name.startswith("stonesoup"):
            raise ImportError(f"No module named {name!r}")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_stonesoup)
    monkeypatch.delitem(sys.modules, "benchmarks.stonesoup_peer")
    with pytest.raises(ImportError, match=r"pip install '\.\[peers\]'"):
        importlib.import_module("benchmarks.stonesoup_peer")
