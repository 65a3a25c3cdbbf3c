"""Both road trackers at a T-junction built by hand: the split, the collapse on a detection, negative
information, and a prediction that stays on the graph.

Figures compared with: at a T-junction met from its stem the two ways on are equally likely (the branch table,
:meth:`RoadGraph.branch_probabilities`, with no straight option), so the road mass splits 1 : 1; a UAV that had
the whole west arm in sight and saw nothing leaves the west arm ``0.5 (1 - P_D) / (0.5 (1 - P_D) + 0.5)`` =
1/11 of the two arms' mass for ``P_D = 0.9`` (Bayes' rule).
"""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.filters.estimate import ns_from_s
from gcs.core.roads.sensing import Looks
from tests.unit.roads._scenes import SENSOR, T_JUNCTION, TRACKERS, detections, edge_of, mass_on, on_stem

WEST = edge_of(T_JUNCTION, (0, 0), (-300, 0))
EAST = edge_of(T_JUNCTION, (0, 0), (300, 0))
UAVS = np.array([[-200.0, 150.0, 200.0], [250.0, 200.0, 210.0], [50.0, -250.0, 220.0]])


def _past_the_junction(name: str, rng: np.random.Generator):
    """20 s unseen after on_stem(): 200 m driven, 100 m past the node."""
    tracker = TRACKERS[name](T_JUNCTION)
    return tracker, tracker.predict(tracker.start(on_stem(), rng), ns_from_s(20.0), rng)


@pytest.mark.parametrize("name", TRACKERS)
def test_probability_splits_between_the_branches_then_collapses_on_a_detection(name: str) -> None:
    rng = np.random.default_rng(11)
    tracker, prior = _past_the_junction(name, rng)
    west, east = mass_on(prior, WEST), mass_on(prior, EAST)
    # 2000 particles: the share's standard error is 0.011; the mixture splits exactly; 0.05 covers both
    assert west / (west + east) == pytest.approx(0.5, abs=0.05)
    assert west + east > 0.7  # most of the mass is past the node, on the road (the rest: off it, or short of it)
    posterior = tracker.update(prior, detections((100.0, 0.0), UAVS, SENSOR, rng), None, rng)
    # the west hypotheses are 200 m from a detection good to about 10 m: their likelihood is nil
    assert mass_on(posterior, WEST) < 1e-3
    assert mass_on(posterior, EAST) > 0.95
    assert np.hypot(*(posterior.mean[:2] - (100.0, 0.0))) < 15.0


@pytest.mark.parametrize("name", TRACKERS)
def test_an_empty_look_down_one_branch_moves_the_mass_to_the_other(name: str) -> None:
    rng = np.random.default_rng(12)
    tracker, prior = _past_the_junction(name, rng)

    def sees(points, vehicle_xyz):  # the one UAV sees the west arm, from 5 m west of the node on
        return np.broadcast_to(points[:, 0] < -5.0, (len(vehicle_xyz), len(points)))

    looks = Looks(np.array([[-150.0, 0.0, 200.0]]), np.array([False]), sees, detection_probability=0.9)
    posterior = tracker.update(prior, [], looks, rng)
    west, east = mass_on(posterior, WEST), mass_on(posterior, EAST)
    # 1/11 = 0.091 (module docstring); 0.03 allows for the mass within 5 m of the node, which the look misses,
    # and the particles' sampling error
    assert west / (west + east) == pytest.approx(1.0 / 11.0, abs=0.03)


@pytest.mark.parametrize("name", TRACKERS)
def test_prediction_stays_on_the_graph_but_for_the_off_road_weight(name: str) -> None:
    rng = np.random.default_rng(13)
    tracker, estimate = _past_the_junction(name, rng)
    horizon = tracker.horizon(estimate, 1.0, 10, rng)
    assert horizon.samples.shape[:2] == horizon.weights.shape and horizon.samples.shape[0] == 10
    np.testing.assert_allclose(horizon.weights.sum(axis=1), 1.0)
    _, _, distance = T_JUNCTION.snap(horizon.samples)
    off_graph = np.where(distance > 1e-6, horizon.weights, 0.0).sum(axis=1)
    assert np.all(off_graph <= horizon.off_road + 1e-9)
    assert np.all(horizon.off_road < 0.5)
    # both streets the car can have taken are in the prediction, each with a good share of the weight
    last = horizon.samples[-1]
    west = horizon.weights[-1][(last[:, 0] < -1.0) & (np.abs(last[:, 1]) < 1e-6)].sum()
    east = horizon.weights[-1][(last[:, 0] > 1.0) & (np.abs(last[:, 1]) < 1e-6)].sum()
    assert min(west, east) > 0.3


@pytest.mark.parametrize("name", TRACKERS)
def test_a_detection_no_hypothesis_explains_restarts_the_track_there(name: str) -> None:
    rng = np.random.default_rng(14)
    tracker, prior = _past_the_junction(name, rng)
    far = np.array([1500.0, 1500.0])  # 1.5 km off every road and every hypothesis
    posterior = tracker.update(prior, detections(far, UAVS + np.append(far, 0.0), SENSOR, rng), None, rng)
    # the restart is drawn about the inverted detections (about 10 m good): the estimate moves there at once
    assert np.hypot(*(posterior.mean[:2] - far)) < 30.0
