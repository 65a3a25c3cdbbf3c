"""The engine with the road tracker, on scripted inputs: a report without a detection is evidence (the road tracker's
negative information), a missing report is none; the plan job carries the branches' samples, the wire their
moment-matched Gaussians.

Figure compared with: the DUIF, for which an empty report and a missing one are the same (it fuses detections
only), on the same inputs.
"""

from __future__ import annotations

import math

import msgspec
import numpy as np

from gcs.config.world import build_world
from gcs.core.roads import RoadHorizon, RoadParticleEstimate
from gcs.engine.engine import Engine, EngineOptions
from gcs.engine.events import Arrived, PlannerFree, PublishTrack, SubmitPlan, Tick
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import alive_key, nav_key, report_key
from protocols.messages import Measurement, NavReport, SensorReport

_PAPER = load_scenario("wang2012_urban")
ROADS = msgspec.structs.replace(_PAPER, target=msgspec.structs.replace(_PAPER.target, motion="streets"),
                                estimator=msgspec.structs.replace(_PAPER.estimator, kind="road"))
WORLD = build_world(_PAPER)
ROSTER = [v.id for v in _PAPER.vehicles]
S = 1_000_000_000
EPOCH_NS = 1_000_000 * S
CAR = (1500.0, 1500.0)
UAV_XYZ = {"uav1": (1200.0, 1500.0, 200.0), "uav2": (1500.0, 1250.0, 210.0), "uav3": (1700.0, 1700.0, 220.0)}


def _report(vehicle: str, stamp_ns: int, detected: bool) -> Arrived:
    x, y, z = UAV_XYZ[vehicle]
    dx, dy = CAR[0] - x, CAR[1] - y
    ground = math.hypot(dx, dy)
    found = (Measurement(range_m=math.hypot(ground, z), range_std_m=10.0, azimuth_rad=math.atan2(dy, dx),
                         azimuth_std_rad=0.05, elevation_rad=-math.atan2(z, ground), elevation_std_rad=0.05),)
    message = SensorReport(vehicle_id=vehicle, seq=1, stamp_ns=stamp_ns, vehicle_position_enu_m=(x, y, z),
                           detections=found if detected else ())
    return Arrived("sample", report_key(vehicle), *encode(message), 0, (stamp_ns - EPOCH_NS) / S)


def _tracks(scenario, blind_steps_report: bool) -> tuple[list, Engine]:
    """Two steps with every UAV on the car, then five in which none sees it: uav1 and uav2 report nothing found,
    and uav3 reports nothing found too, or sends no report (the step goes when its wait runs out)."""
    engine = Engine(scenario, WORLD, EngineOptions(planner="pursuit"))
    for vehicle in ROSTER:
        engine.feed(Arrived("alive", alive_key(vehicle), b"", "", 0, 0.0))
        heading = NavReport(vehicle_id=vehicle, seq=1, stamp_ns=EPOCH_NS, velocity_enu_mps=(25.0, 0.0, 0.0),
                            heading_rad=0.0)
        engine.feed(Arrived("sample", nav_key(vehicle), *encode(heading), 0, 0.0))
    tracks = []
    for k in range(7):
        stamp = EPOCH_NS + k * S
        for vehicle in ROSTER if k < 2 or blind_steps_report else ROSTER[:2]:
            engine.feed(_report(vehicle, stamp, detected=k < 2))
        actions = engine.feed(Tick(k + 0.9))
        tracks += [a.track for a in actions if isinstance(a, PublishTrack)]
    return tracks, engine


def test_an_empty_report_is_evidence_for_the_road_tracker_and_not_for_the_duif() -> None:
    reported, engine = _tracks(ROADS, blind_steps_report=True)
    missing, _ = _tracks(ROADS, blind_steps_report=False)
    assert len(reported) == len(missing) == 7
    assert isinstance(engine.loop.estimate, RoadParticleEstimate)
    assert reported[:2] == missing[:2] and reported[2:] != missing[2:]
    duif = msgspec.structs.replace(ROADS, estimator=msgspec.structs.replace(ROADS.estimator, kind="duif"))
    assert _tracks(duif, True)[0] == _tracks(duif, False)[0]


def test_the_plan_job_carries_the_branches_samples_and_the_wire_their_gaussians() -> None:
    tracks, engine = _tracks(ROADS, blind_steps_report=True)
    (submit,) = [a for a in engine.feed(PlannerFree(7.0)) if isinstance(a, SubmitPlan)]
    predicted = submit.job.predicted
    steps = ROADS.planner.sight.horizon_steps
    assert isinstance(predicted, RoadHorizon) and predicted.samples.shape == (steps, 64, 2)
    np.testing.assert_allclose(predicted.weights.sum(axis=1), 1.0)
    last = tracks[-1]
    assert last.stamp_ns == submit.job.stamp_ns and last.model == "cv2d"
    assert np.array_equal(last.state, engine.loop.estimate.mean)  # the mixture mean
    mean = np.einsum("ts,tsa->ta", predicted.weights, predicted.samples)  # the samples' own weighted mean
    np.testing.assert_allclose([p.position_enu_m for p in last.prediction], mean, atol=1e-9)
