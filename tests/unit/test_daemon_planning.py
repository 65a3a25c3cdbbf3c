"""The daemon's planners (inline, thread, process): same plans, the newest step wins, failures are contained."""

from __future__ import annotations

import time

import numpy as np
import pytest

from gcs.config.world import build_world
from gcs.core.filters.uif import GaussianEstimate
from gcs.core.kinematics import VehicleState
from gcs.core.tracker import TrackerState, prediction
from gcs.daemon.plan_process import ProcessPlanRunner
from gcs.daemon.plan_runners import PLAN_RUNNERS
from gcs.engine.plan_jobs import PlanJob
from gcs.daemon.plan_runner_start import start_plan_runner
from gcs.scenarios import load_scenario
from gcs.engine.tracker_factory import subset_config, tracker_config

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
PLANNER = "orbit"  # deterministic and quick: the modes must agree exactly
TRACKER = tracker_config(SCENARIO, WORLD, PLANNER)
ROSTER = tuple(v.id for v in SCENARIO.vehicles)


def _configs(indices: tuple[int, ...]):
    return subset_config(TRACKER, indices)


def _job(index: int, indices: tuple[int, ...] = (0, 1, 2), broken: bool = False) -> PlanJob:
    tx, ty = SCENARIO.target.start_enu_m
    mean = np.array([tx + 10.0 * index, ty, 5.0, 0.0])
    estimate = GaussianEstimate(mean, np.diag([100.0, 100.0, 4.0, 4.0]), index * 1_000_000_000)
    vehicles = VehicleState(np.array([SCENARIO.vehicles[i].start_enu_m for i in indices], dtype=float),
                            np.zeros(len(indices)), np.full(len(indices), 30.0), np.full(len(indices), 300.0))
    state = TrackerState(estimate, None, np.zeros(len(indices)))
    if broken:  # states of one vehicle fewer than the tracker's sensors: the planner raises
        vehicles = VehicleState(vehicles.xy[:-1], vehicles.heading[:-1], vehicles.speed[:-1], vehicles.altitude[:-1])
    return PlanJob(index=index, stamp_ns=estimate.stamp_ns, active=tuple(ROSTER[i] for i in indices),
                   indices=indices, state=state, vehicles=vehicles, predicted=prediction(TRACKER, estimate),
                   clock_scale=1.0, submitted_s=time.monotonic())


def _wait_for(planner, count: int, timeout_s: float = 60.0) -> list:
    done, deadline = [], time.monotonic() + timeout_s
    while len(done) < count:
        assert time.monotonic() < deadline, f"only {len(done)} of {count} plans within {timeout_s} s"
        done += planner.take()
        time.sleep(0.005)
    return done


@pytest.fixture(params=PLAN_RUNNERS)
def planner(request):
    started = start_plan_runner(request.param, SCENARIO, WORLD, PLANNER, seed=3, configs=_configs)
    yield started
    started.close()


def test_every_mode_plans_the_same_as_the_pure_planner(planner) -> None:
    from gcs.core.tracker import plan

    job = _job(1)
    planner.submit(job)
    (outcome,) = _wait_for(planner, 1)
    expected, turn_rates, _ = plan(TRACKER, job.state, job.vehicles, np.random.default_rng(3),
                                   predicted=job.predicted)
    assert outcome.error is None and outcome.job.index == 1
    np.testing.assert_array_equal(outcome.state.plan, expected.plan)
    np.testing.assert_array_equal(outcome.turn_rates, turn_rates)
    assert 0.0 <= outcome.waited_s and 0.0 < outcome.planning_s and outcome.solve_s is not None


def test_finished_says_when_an_outcome_waits_to_be_taken(planner) -> None:
    # the loop's idle wait wakes on it, so that a finished plan is commanded at once
    assert not planner.finished()
    planner.submit(_job(1))
    deadline = time.monotonic() + 60.0
    while not planner.finished():
        assert time.monotonic() < deadline, "no outcome within 60 s"
        time.sleep(0.005)
    (outcome,) = planner.take()
    assert outcome.job.index == 1 and not planner.finished() and not planner.busy


def test_a_subset_of_the_roster_is_planned_with_its_own_sensors(planner) -> None:
    planner.submit(_job(2, indices=(0, 2)))
    (outcome,) = _wait_for(planner, 1)
    assert outcome.job.active == ("uav1", "uav3") and outcome.state.plan.shape[0] == 2


def test_a_job_that_fails_is_reported_and_planning_goes_on(planner) -> None:
    planner.submit(_job(1, broken=True))
    (failed,) = _wait_for(planner, 1)
    assert failed.error is not None and failed.state is None
    planner.submit(_job(2))
    (outcome,) = _wait_for(planner, 1)
    assert outcome.error is None and outcome.job.index == 2


@pytest.mark.parametrize("mode", ["thread", "process"])
def test_jobs_handed_over_while_the_planner_is_busy_keep_only_the_newest(mode: str) -> None:
    planner = start_plan_runner(mode, SCENARIO, WORLD, PLANNER, seed=3, configs=_configs)
    try:
        for index in range(1, 6):
            planner.submit(_job(index))
        done, deadline = [], time.monotonic() + 60.0
        while not done or done[-1].job.index != 5:
            assert time.monotonic() < deadline, f"plans {[o.job.index for o in done]}: step 5 never planned"
            done += planner.take()
            time.sleep(0.005)
        indices = [o.job.index for o in done]
        # at most the job the planner had already started, then the newest; the ones between were replaced
        assert indices in ([5], [1, 5]) and planner.superseded == 5 - len(indices) and not planner.busy
    finally:
        planner.close()


def test_a_planner_process_that_dies_is_started_again() -> None:
    planner = ProcessPlanRunner(SCENARIO, WORLD, PLANNER, seed=3)
    try:
        planner.submit(_job(1))
        _wait_for(planner, 1)
        planner._process.kill()
        planner._process.join(5.0)
        planner.submit(_job(2))  # finds the process dead: starts another and plans there
        (outcome,) = _wait_for(planner, 1)
        assert outcome.job.index == 2 and outcome.error is None and planner.restarts == 1
        planner.submit(_job(3))
        planner._process.kill()  # most likely with job 3 in flight: it is lost, and job 4 is planned
        planner._process.join(5.0)
        planner.submit(_job(4))
        done, deadline = [], time.monotonic() + 60.0
        while not done or done[-1].job.index != 4:
            assert time.monotonic() < deadline, "the dead planner process was not noticed"
            done += planner.take()
            time.sleep(0.01)
        assert planner.restarts == 2 and {o.job.index for o in done} <= {3, 4} and done[-1].error is None
    finally:
        planner.close()
    assert not planner._process.is_alive()


@pytest.mark.parametrize("niceness", [0, 7])
def test_the_planner_process_runs_that_much_below_the_daemon(niceness: int) -> None:
    import os

    planner = ProcessPlanRunner(SCENARIO, WORLD, PLANNER, seed=3, niceness=niceness)
    try:
        planner.submit(_job(1))
        _wait_for(planner, 1)  # the child has reniced itself before it said it was ready
        ours = os.getpriority(os.PRIO_PROCESS, 0)
        assert os.getpriority(os.PRIO_PROCESS, planner._process.pid) == min(ours + niceness, 19)
    finally:
        planner.close()


def test_a_niceness_outside_0_19_is_refused() -> None:
    with pytest.raises(ValueError, match="0-19"):
        ProcessPlanRunner(SCENARIO, WORLD, PLANNER, seed=3, niceness=20)
