"""RoadMultiTargetTracker on a crossroads built by hand: a car that turns out of sight keeps its id, two cars
crossing keep theirs, and the same scans give the same tracks bit for bit.

The cars' detections are made with the tests' own formulas (``_scenes.scan_detections``), never the filters'
``h(x)``. The plain tracker (:class:`MultiTargetTracker`, the same association and lifecycle on a constant-velocity
Gaussian) is run on the same scans as the figure to compare with.
"""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.multitarget import MultiTargetTracker
from gcs.core.multitarget.road_tracker import RoadMultiTargetTracker
from gcs.core.roads import RoadGraph, RoadParticleFilter

from ._scenes import CLUTTER_VOLUME, scan_detections

SECOND_NS = 1_000_000_000
SENSOR = SensorModel.range_bearing(10.0, 0.02, 0.02)
STD = np.array(SENSOR.std)
CROSSROADS = RoadGraph.from_segments([(0.0, -600.0), (0.0, 0.0), (-600.0, 0.0), (0.0, 0.0)],
                                     [(0.0, 0.0), (0.0, 600.0), (0.0, 0.0), (600.0, 0.0)])
"""Two straight roads, north-south and east-west, crossing at the origin; 600 m arms."""
VEHICLES = np.array([[-500.0, -400.0, 200.0], [450.0, -450.0, 210.0], [0.0, 500.0, 220.0]])
COMMON = {"motion": constant_velocity(2.0), "detection_probability": 0.9, "max_misses": 3,
          "clutter_density": 1.0 / CLUTTER_VOLUME}


def _in_shadow(points: np.ndarray) -> np.ndarray:
    """Ground points (N, 2) behind the buildings around the junction: within 40 m of it, or on the east arm up to
    90 m from it."""
    return (np.hypot(points[:, 0], points[:, 1]) < 40.0) | ((points[:, 0] > 0.0) & (points[:, 0] < 90.0)
                                                            & (np.abs(points[:, 1]) < 20.0))


def _sees(points: np.ndarray, vehicle_xyz: np.ndarray) -> np.ndarray:
    """Every UAV sees every ground point out of the shadow."""
    return np.broadcast_to(~_in_shadow(points), (len(vehicle_xyz), len(points)))


def _turning_car(k: int) -> np.ndarray:
    """North at 10 m/s from 200 m south of the junction, through it at k = 20, then east: in the shadow for
    k = 17 .. 28."""
    return np.array([0.0, 10.0 * k - 200.0]) if k <= 20 else np.array([10.0 * (k - 20), 0.0])


def _run(tracker, truths, rng, clutter=0.0):
    """Scans 1 s apart of the cars ``truths[k]`` (T, 2) out of the shadow; the tracker's states."""
    state, states = tracker.start(), []
    for k, cars in enumerate(truths):
        scans = dict(enumerate(scan_detections(rng, cars[~_in_shadow(cars)], VEHICLES, STD, 0.9, clutter)))
        in_view = lambda xy: ~_in_shadow(xy)  # noqa: E731
        if isinstance(tracker, RoadMultiTargetTracker):
            state, _ = tracker.scan(state, k * SECOND_NS, scans, SENSOR, in_view, dict(enumerate(VEHICLES)))
        else:
            state, _ = tracker.scan(state, k * SECOND_NS, scans, SENSOR, in_view)
        states.append(state)
    return states


def _track_on(state, xy, within_m: float = 30.0) -> int | None:
    """The id of the confirmed track nearest ``xy`` if within ``within_m``."""
    confirmed = state.tracks.confirmed()
    if not confirmed.size:
        return None
    gap = np.linalg.norm(confirmed.mean[:, :2] - xy, axis=1)
    return int(confirmed.ids[gap.argmin()]) if gap.min() <= within_m else None


def _road(**kw) -> RoadMultiTargetTracker:
    return RoadMultiTargetTracker(roads=RoadParticleFilter(CROSSROADS), sees=_sees, **COMMON, **kw)


@pytest.mark.parametrize("association", ["gnn", "jpda"])
def test_a_car_turning_out_of_sight_keeps_its_id_where_the_plain_tracker_starts_a_new_one(association) -> None:
    """Seen on the south arm, hidden for 12 s while it crosses the junction and turns east, seen again 90 m
    down the east arm. The plain track coasts north out of the shadow, is missed there and deleted, and the car
    reappears as a new track; the road track's branches north and west come out of the shadow empty, so its
    weight moves east, where the car reappears."""
    truths = [_turning_car(k)[None] for k in range(35)]
    road = _run(_road(association=association), truths, np.random.default_rng(4))
    plain = _run(MultiTargetTracker(association=association, **COMMON), truths, np.random.default_rng(4))
    before, after = _turning_car(16), _turning_car(34)
    assert _track_on(road[16], before) is not None and _track_on(plain[16], before) is not None
    assert _track_on(road[34], after) == _track_on(road[16], before)  # the same id, 140 m down the east arm
    assert _track_on(plain[34], after) not in (None, _track_on(plain[16], before))  # a new one
    assert road[34].tracks.confirmed().size == 1  # and no other track left behind
    assert np.linalg.norm(road[34].tracks.confirmed().mean[0, :2] - after) < 15.0


def test_the_looks_move_the_hidden_car_s_weight_into_the_shadow() -> None:
    """At k = 28 the car has been in the shadow for 12 s, 80 m down the east arm. Without looks the branch table
    gives the east arm a quarter (a turn of two at a crossroads, straight on a half), and most of the cloud has
    driven out of the shadow north, west or back south. With them, what came out of the shadow was seen empty by
    three UAVs (a factor 0.1 each a scan): nothing is left there; the weight is on the east arm, and in the
    shadow of the junction (cars that slowed down)."""
    truths = [_turning_car(k)[None] for k in range(29)]
    kept = {"min_existence": 0.0, **COMMON, "max_misses": 100}  # the track kept in both, to be looked at
    with_looks = _run(RoadMultiTargetTracker(roads=RoadParticleFilter(CROSSROADS), sees=_sees, association="jpda",
                                             **kept), truths, np.random.default_rng(5))[28]
    blind = RoadMultiTargetTracker(roads=RoadParticleFilter(CROSSROADS), association="jpda", **kept)  # no looks
    without = _run(blind, truths, np.random.default_rng(5))[28]

    def shares(state) -> tuple[float, float]:
        xy = state.clouds.rows("xy")[0]
        weights = np.exp(state.clouds.log_weights[0])
        east = (xy[:, 0] > 15.0) & (np.abs(xy[:, 1]) < 30.0)
        return float(weights[east].sum()), float(weights[~east & ~_in_shadow(xy)].sum())

    east, seen_elsewhere = shares(with_looks)
    assert east > 0.5 and seen_elsewhere < 0.02
    east, seen_elsewhere = shares(without)
    assert east < 0.4 and seen_elsewhere > 0.4


@pytest.mark.parametrize("association", ["gnn", "jpda"])
def test_two_cars_crossing_the_junction_together_keep_their_ids(association) -> None:
    """Two cars pass the junction at the same time, one north, one east, out of the shadow (seen all along):
    their tracks are on different streets, never unresolved, and each keeps its id across the junction."""
    crossing = [np.array([[45.0, -150.0 + 10.0 * k], [-150.0 + 10.0 * k, 45.0]]) for k in range(30)]
    graph = RoadGraph.from_segments([(45.0, -600.0), (-600.0, 45.0)], [(45.0, 600.0), (600.0, 45.0)])
    tracker = RoadMultiTargetTracker(roads=RoadParticleFilter(graph), sees=_sees, association=association, **COMMON)
    states = _run(tracker, crossing, np.random.default_rng(7))
    ids_before = [_track_on(states[10], car) for car in crossing[10]]
    ids_after = [_track_on(states[-1], car) for car in crossing[-1]]
    assert None not in ids_before and ids_after == ids_before and len(set(ids_after)) == 2


def test_the_same_scans_give_the_same_tracks_bit_for_bit_and_another_seed_other_particles() -> None:
    truths = [np.stack([_turning_car(k), np.array([-250.0 + 8.0 * k, 0.0])]) for k in range(25)]
    runs = [_run(_road(association="jpda", seed=seed), truths, np.random.default_rng(8), 2.0) for seed in (0, 0, 1)]
    first, again, other = (run[-1] for run in runs)
    assert np.array_equal(first.tracks.ids, again.tracks.ids)
    for name in ("mean", "cov", "status", "window", "misses"):
        assert np.array_equal(getattr(first.tracks, name), getattr(again.tracks, name))
    for name in ("edge", "s", "speed", "on_road", "xy", "vxy", "log_weight"):
        assert np.array_equal(getattr(first.clouds.cloud, name), getattr(again.clouds.cloud, name))
    assert np.array_equal(first.clouds.existence, again.clouds.existence)
    assert not np.array_equal(first.clouds.cloud.s, other.clouds.cloud.s)
