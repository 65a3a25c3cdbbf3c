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

from benchmarks.stonesoup_peer import PeerConfig, gnn_tracker, jpda_tracker, measurement, run_peer
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


CONFIG = PeerConfig(pd=0.9, clutter_density=2e-5, target_height_m=0.0)


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


def test_measurement_is_elevation_bearing_range_with_the_sensors_variances():
    vehicle = np.array([10.0, -20.0, 300.0])
    values = np.array([700.0, 0.4, -0.45])  # range, azimuth, elevation
    vector, noise = measurement(Detection(0, vehicle, values), SENSOR)
    np.testing.assert_allclose(np.asarray(vector, dtype=float).ravel(), [-0.45, 0.4, 700.0])
    np.testing.assert_allclose(np.diag(noise), [0.02**2, 0.01**2, 5.0**2])
    # zuo2021 eq. (2): beyond the reference range every variance grows as (rho / rho0)^2
    far = SensorModel.range_bearing(5.0, 0.01, 0.02, distance_dependent=True, reference_range_m=250.0)
    _, far_noise = measurement(Detection(0, vehicle, values), far)
    np.testing.assert_allclose(np.diag(far_noise), np.diag(noise) * (700.0 / 250.0) ** 2)
    with pytest.raises(ValueError, match="range, azimuth and elevation"):
        measurement(Detection(0, vehicle, values[1:2]), SensorModel.bearing_only(0.01))


def test_same_scans_same_tracks_every_run():
    """The detections and tracks are ordered and numbered: two runs give the same ids and the same numbers."""
    _, scans = _scene(seed=7)
    first, second = (run_peer(jpda_tracker(CONFIG), scans) for _ in range(2))
    assert first.tracks == second.tracks


def _one_target(seen: list[bool], covered: bool):
    """Scans of one still target under two vehicles, detected (by both) on the scans ``seen`` says, no clutter; the
    coverage says every scan whether the UAVs looked."""
    target = np.array([[100.0, 50.0]])
    rng = np.random.default_rng(3)
    scans = []
    for k, detected in enumerate(seen):
        angle = 0.05 * k + np.array([0.0, np.pi])
        vehicles = np.column_stack([400.0 * np.cos(angle), 400.0 * np.sin(angle), np.full(2, ALT_M)])
        sc = scan(target, vehicles, SENSOR, pd=1.0 if detected else 0.0, clutter_rate=0.0, max_range_m=RANGE_M, rng=rng)
        scans.append((int(k * 1e9), dict(enumerate(sc.detections)), SENSOR,
                      lambda xy, c=covered: np.full(len(xy), c)))
    return scans


@pytest.mark.parametrize("make", [gnn_tracker, jpda_tracker], ids=["gnn", "jpda"])
def test_a_track_out_of_every_view_coasts_and_a_covered_one_is_deleted(make):
    seen = [True] * 6 + [False] * 8  # 8 scans without a detection, more than max_missed_scans = 5
    hidden = run_peer(make(CONFIG), _one_target(seen, covered=False))
    looked = run_peer(make(CONFIG), _one_target(seen, covered=True))
    assert [len(t) for t in hidden.tracks[5:]] == [1] * 9  # behind the buildings: kept, one track throughout
    assert len({tid for tracks in hidden.tracks[5:] for tid, _, _ in tracks}) == 1
    counts = [len(t) for t in looked.tracks]
    assert counts[5:10] == [1] * 5 and counts[10:] == [0] * 4  # the 5th covered miss (scan 10) deletes it


@pytest.mark.parametrize("make", [gnn_tracker, jpda_tracker], ids=["gnn", "jpda"])
def test_confirmed_on_the_third_scan_with_a_hit_as_ours(make):
    """3 of 4 scans, whatever the number of vehicles: two vehicles' four updates on scans 0-1 do not confirm."""
    steady = run_peer(make(CONFIG), _one_target([True] * 4, covered=True))
    assert [len(t) for t in steady.tracks] == [0, 0, 1, 1]
    gap = run_peer(make(CONFIG), _one_target([True, False, True, True, True], covered=True))
    assert [len(t) for t in gap.tracks] == [0, 0, 0, 1, 1]
    lost = run_peer(make(CONFIG), _one_target([True, False, False, True, True, True], covered=True))
    assert [len(t) for t in lost.tracks][:5] == [0] * 5  # hopeless after two misses: a new track starts on scan 3
    assert len(lost.tracks[5]) == 1 and lost.tracks[5][0][0] == "2"


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
