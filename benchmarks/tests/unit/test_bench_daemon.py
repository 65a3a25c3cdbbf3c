"""The daemon benchmark's pure parts: the latency bookkeeping, the rate search and the load's geometry."""

from __future__ import annotations

import math
import time
from dataclasses import fields

import pytest

from benchmarks.daemon_report import worst_latency
from benchmarks.daemon import (GOAL_REPORTS_PER_S, MAX_TRIALS, PlanTiming, StepTiming, Trial, next_rate,
                              step_latencies_ms, track_latencies_ms)
from benchmarks.daemon_load import Fleet, Load
from benchmarks.urban import with_vehicles
from gcs.scenarios import load_scenario

MS = 1_000_000


def _trial(rate: float, passed: bool) -> Trial:
    return Trial(**{f.name: 1 for f in fields(Trial)} | {"rate_per_s": rate, "passed": passed})


def test_a_step_fused_while_the_planner_was_busy_is_served_by_the_next_plan_less_the_planners_share() -> None:
    sent = {100: 0, 200: 5 * MS, 300: 6 * MS}
    steps = [StepTiming(50, 0), StepTiming(100, 1 * MS), StepTiming(200, 7 * MS), StepTiming(300, 8 * MS)]
    plans = [
        PlanTiming(50, 1 * MS, 2 * MS, 0.001, 0.001),  # warm-up plan: serves none of the trial's steps
        PlanTiming(200, 18 * MS, 20 * MS, 0.004, 0.003),  # serves 100 (planned without) and 200
        PlanTiming(300, 29 * MS, 30 * MS, 0.010, 0.008),
    ]
    # (fused - sent) + (put - finished)
    assert step_latencies_ms(sent, steps, plans) == pytest.approx([1.0 + 2.0, 2.0 + 2.0, 2.0 + 1.0])
    assert step_latencies_ms(sent, steps, plans, planner=True) == pytest.approx([20.0, 15.0, 24.0])


def test_a_step_never_planned_or_never_fused_has_no_latency() -> None:
    plans = [PlanTiming(50, 4 * MS, 5 * MS, 0.001, 0.001)]
    assert step_latencies_ms({100: 0}, [StepTiming(100, 1 * MS)], plans) == []
    assert step_latencies_ms({10: 0}, [], plans) == []


def test_the_track_latency_is_from_the_last_report_to_the_steps_fusion() -> None:
    steps = [StepTiming(50, 1 * MS), StepTiming(100, 3 * MS), StepTiming(200, 7 * MS)]
    assert track_latencies_ms({100: 1 * MS, 200: 5 * MS}, steps) == pytest.approx([2.0, 2.0])


def test_the_rate_search_doubles_from_a_quarter_of_the_goal_then_bisects() -> None:
    assert next_rate([], minimum=10) == GOAL_REPORTS_PER_S / 4
    trials = [_trial(1250, True), _trial(2500, True)]
    assert next_rate(trials, minimum=10) == 5000
    trials.append(_trial(5000, False))
    assert next_rate(trials, minimum=10) == 3750
    trials += [_trial(3750, True), _trial(4375, True)]
    assert next_rate(trials, minimum=10) is None  # 5000 / 4375 is within the 15% resolution


def test_the_rate_search_halves_after_a_first_failure_down_to_the_minimum() -> None:
    assert next_rate([_trial(1250, False)], minimum=10) == 625
    assert next_rate([_trial(1250, False), _trial(625, False)], minimum=400) is None


def test_the_rate_search_stops_after_the_last_trial() -> None:
    trials = [_trial(1250 * 2**k, True) for k in range(MAX_TRIALS)]
    assert next_rate(trials, minimum=10) is None


def test_every_simulated_report_points_at_the_target() -> None:
    scenario = with_vehicles(load_scenario("wang2012_urban"), 12)
    fleet = Fleet.of(scenario)
    tx, ty = scenario.target.start_enu_m
    assert len(fleet.vehicles) == 12 and fleet.step_ns == 1_000_000_000
    for v in fleet.vehicles:
        x, y, z = v.position_enu_m
        ground = v.range_m * math.cos(v.elevation_rad)
        assert x + ground * math.cos(v.azimuth_rad) == pytest.approx(tx)
        assert y + ground * math.sin(v.azimuth_rad) == pytest.approx(ty)
        assert z + v.range_m * math.sin(v.elevation_rad) == pytest.approx(0.0, abs=1e-9)
        assert all(type(c) is float for c in v.position_enu_m)  # msgspec cannot encode numpy scalars


def test_the_loads_gps_fix_is_where_the_vehicle_is() -> None:
    # with nav_per_round the daemon's navigation fuses these fixes: they must put each vehicle where its reports do
    from gcs.core.geometry import LocalFrame

    scenario = with_vehicles(load_scenario("wang2012_urban"), 10)
    fleet = Fleet.of(scenario, nav_per_round=True)
    frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
    assert fleet.nav_per_round and len(fleet.vehicles) == 10
    for vehicle in fleet.vehicles:
        back = frame.to_enu(*vehicle.lat_lon_alt)
        assert math.dist(back, vehicle.position_enu_m) < 1e-3


def test_the_latency_goals_line_names_the_team_size_that_missed_it() -> None:
    def row(p99, at=GOAL_REPORTS_PER_S):
        return {"latency_ms_p50": 5.0, "latency_ms_p99": p99, "latency_at_reports_per_s": at}

    report = {"goals": {"reports_per_s": GOAL_REPORTS_PER_S},
              "vehicles": {"10": row(12.6), "50": row(21.4), "100": row(18.6)}}
    assert worst_latency(report) == "worst at 50 vehicles: p50 5.00 ms, p99 21.40 ms"
    report["vehicles"]["10"] = row(None, 2500)  # never reached the goal's rate: the worst
    assert worst_latency(report).startswith("worst at 10 vehicles at 2500 reports/s")


class _TimedPublisher:
    """A publisher whose ``put`` notes when it began (``time.time_ns``) and takes 0.2 ms."""

    def __init__(self) -> None:
        self.put_ns: list[int] = []

    def put(self, payload: bytes) -> None:
        self.put_ns.append(time.time_ns())
        busy_until = time.perf_counter() + 2e-4
        while time.perf_counter() < busy_until:
            pass


def test_a_rounds_send_time_is_read_before_its_last_report_is_put() -> None:
    # Read after the put, a load preempted as the daemon wakes would shorten the latency it measures.
    fleet = Fleet.of(with_vehicles(load_scenario("wang2012_urban"), 4))
    load = Load.__new__(Load)  # no Zenoh session: the publishers are stand-ins
    load.fleet, load.next_round, load.seq, load._prepared = fleet, 0, 0, None
    load.reports = [_TimedPublisher() for _ in fleet.vehicles]
    load.navs = [_TimedPublisher() for _ in fleet.vehicles]
    assert load.prepare(rate=1e6, seconds=1e-5 * 4)["rounds"] == 10
    sent = load.run()
    last_puts = load.reports[-1].put_ns
    assert sent["published"] == 40 and len(sent["last_sent_ns"]) == len(last_puts) == 10
    assert all(first_put <= sent_ns <= last_put for sent_ns, first_put, last_put in
               zip(sent["last_sent_ns"], load.reports[0].put_ns, last_puts))


def test_the_bench_parsers_defaults_are_the_modules_own() -> None:
    # the parser does not import the benchmark's modules (it stays light), so their constants are repeated there
    from benchmarks import system_arguments as cli
    from benchmarks.daemon_load import LOAD_NICENESS
    from gcs.engine.navigation import NAVIGATION_MODES

    assert cli.LOAD_NICENESS == LOAD_NICENESS and cli.DAEMON_NAVIGATION == NAVIGATION_MODES
