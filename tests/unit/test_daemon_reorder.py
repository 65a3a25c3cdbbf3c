"""The reorder window (gcs.engine.steps, gcs.engine.ingest), property-tested.

A stream of reports (three vehicles, one report per step each, some skipped,
stamps jittered) is sent ``D`` wall seconds per step and every report is
delayed at random. Inside the documented window (delay below
``min(max_wait_s - D / 2, 1.5 D)``) the released steps must equal those of the
same reports filed in stamp order; outside it every report is used once or
counted late, never used out of order, and nothing raises.
"""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.adapters.zenoh_io import Received
from gcs.engine.ingest import REORDER_WINDOW_NS, Ingest
from gcs.engine.steps import ReadyStep, StepAssembler
from protocols.codec import encode
from protocols.keys import nav_key, report_key
from protocols.messages import NavReport, SensorReport

S = 1_000_000_000
VEHICLES = ("uav1", "uav2", "uav3")
MAX_WAIT_S = 0.5
EPOCH_NS = 1_000 * S


def _report(vehicle: str, stamp_ns: int, seq: int) -> SensorReport:
    return SensorReport(vehicle_id=vehicle, seq=seq, stamp_ns=stamp_ns, vehicle_position_enu_m=(0.0, 0.0, 100.0))


@st.composite
def streams(draw, max_delay_factor: float | None):
    """(reports with their send times, delays, wall seconds per step).

    ``max_delay_factor`` None draws delays inside the window; a number draws them
    up to that many step durations (inside or outside it)."""
    step_wall = draw(st.floats(0.02, 0.8))
    steps = draw(st.integers(1, 10))
    reports, sends = [], []
    for k in range(steps):
        for vehicle in VEHICLES:
            if k > 0 and draw(st.integers(0, 9)) == 0:  # about one report in ten is skipped
                continue
            jitter = draw(st.floats(-0.24, 0.24))
            reports.append(_report(vehicle, EPOCH_NS + round((k + jitter) * S), k + 1))
            sends.append((k + jitter) * step_wall)
    if max_delay_factor is None:
        limit = min(MAX_WAIT_S - step_wall / 2, 1.5 * step_wall) * 0.999
    else:
        limit = max_delay_factor * step_wall
    delays = [draw(st.floats(0.0, limit)) for _ in reports]
    return reports, sends, delays, step_wall


def _assemble(reports, arrivals, expected: set[str] = set(VEHICLES)) -> tuple[list[ReadyStep], StepAssembler]:
    """Feed reports in arrival order as the daemon's loop does: release what is due, file, release."""
    steps = StepAssembler(step_ns=S, max_wait_s=MAX_WAIT_S)
    out: list[ReadyStep] = []
    for arrival, report in sorted(zip(arrivals, reports), key=lambda pair: pair[0]):
        out += steps.ready(expected, arrival)
        steps.add(report, arrival)
        out += steps.ready(expected, arrival)
    out += steps.ready(expected, math.inf)
    return out, steps


def _in_stamp_order(reports, expected: set[str] = set(VEHICLES)) -> list[ReadyStep]:
    steps = StepAssembler(step_ns=S, max_wait_s=MAX_WAIT_S)
    for report in sorted(reports, key=lambda r: r.stamp_ns):
        steps.add(report, 0.0)
    return steps.ready(expected, math.inf)


@settings(max_examples=150, deadline=None)
@given(streams(max_delay_factor=None))
def test_any_arrival_order_inside_the_window_gives_the_steps_of_the_sorted_stream(stream) -> None:
    reports, sends, delays, _ = stream
    released, steps = _assemble(reports, [s + d for s, d in zip(sends, delays)])
    assert released == _in_stamp_order(reports)
    assert steps.counters["rejected.late"] == 0
    assert sum(len(step.reports) for step in released) == len(reports)


@settings(max_examples=150, deadline=None)
@given(streams(max_delay_factor=8.0))
def test_outside_the_window_every_report_is_used_once_in_its_own_step_or_counted_late(stream) -> None:
    reports, sends, delays, _ = stream
    released, steps = _assemble(reports, [s + d for s, d in zip(sends, delays)])
    used = [r for step in released for r in step.reports]
    assert len(used) + steps.counters["rejected.late"] == len(reports)
    assert len(set(used)) == len(used)
    indices = [step.index for step in released]
    assert indices == sorted(set(indices))  # in order, each once
    for step in released:
        assert [r.stamp_ns for r in step.reports] == sorted(r.stamp_ns for r in step.reports)
        assert all(steps.index_of(r.stamp_ns) == step.index for r in step.reports)
        assert step.stamp_ns == steps.stamp_of(step.index)


def test_a_vehicle_whose_reports_swap_keeps_both_and_one_two_steps_late_is_counted() -> None:
    steps = StepAssembler(step_ns=S, max_wait_s=MAX_WAIT_S)
    both = {"uav1", "uav2"}
    for vehicle in both:
        steps.add(_report(vehicle, 0, 1), 0.0)
    assert [s.index for s in steps.ready(both, 0.5)] == [0]
    steps.add(_report("uav2", 1 * S, 2), 0.6)
    steps.add(_report("uav1", 2 * S, 3), 0.6)  # uav1's step 2 before its step 1
    assert steps.ready(both, 0.61) == []  # step 1 still waits for uav1
    steps.add(_report("uav1", 1 * S, 2), 0.65)
    (one,) = steps.ready(both, 0.65)
    assert [(r.vehicle_id, r.stamp_ns) for r in one.reports] == [("uav1", S), ("uav2", S)]
    steps.add(_report("uav2", 3 * S, 4), 0.7)
    steps.add(_report("uav2", 4 * S, 5), 0.7)  # uav2 is two steps on: step 2 no longer waits for it
    steps.add(_report("uav1", 3 * S, 4), 0.7)
    assert [s.index for s in steps.ready(both, 0.7)] == [2, 3]
    assert not steps.add(_report("uav2", 2 * S, 3), 0.75)  # its step is gone: late, not used
    assert steps.counters["rejected.late"] == 1


def _sample(message) -> Received:
    key = report_key(message.vehicle_id) if isinstance(message, SensorReport) else nav_key(message.vehicle_id)
    payload, encoding = encode(message)
    return Received("sample", key, payload, encoding, 0)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(VEHICLES), st.sampled_from(["report", "nav"]),
                          st.integers(-30, 30), st.integers(1, 5)), min_size=1, max_size=60))
def test_ingest_accepts_each_stamp_once_and_counts_every_duplicate_and_stale_one(items) -> None:
    """Stamps repeat (re-sent samples, restarted sequence numbers) and go back and forth in time."""
    ingest = Ingest(set(VEHICLES))
    accepted: set[tuple[str, str, int]] = set()
    newest: dict[tuple[str, str], int] = {}
    for vehicle, kind, second, seq in items:
        stamp = EPOCH_NS + second * S // 2
        message = (_report(vehicle, stamp, seq) if kind == "report" else
                   NavReport(vehicle_id=vehicle, seq=seq, stamp_ns=stamp, velocity_enu_mps=(1.0, 0.0, 0.0)))
        key = (vehicle, kind, stamp)
        duplicate = key in accepted
        stale = not duplicate and stamp < newest.get((vehicle, kind), stamp) - REORDER_WINDOW_NS
        result = ingest.accept(_sample(message))
        assert (result is None) == (duplicate or stale)
        if result is not None:
            accepted.add(key)
            newest[(vehicle, kind)] = max(newest.get((vehicle, kind), stamp), stamp)
    counts = ingest.counters
    assert counts["accepted.report"] + counts["accepted.nav"] == len(accepted)
    assert counts["accepted.report"] + counts["accepted.nav"] + counts["rejected.duplicate"] \
        + counts["rejected.stale"] == len(items)


def test_a_whole_step_overtaken_by_the_next_is_still_used_and_the_earliest_stamp_sets_the_grid() -> None:
    """Steps 0.2 s apart: all of step 0 arrives after all of step 1 (each within 0.3 s of sending)."""
    both = {"uav1", "uav2"}
    reports = [_report(v, EPOCH_NS + k * S + (S // 5 if v == "uav2" else -S // 5), k + 1)
               for k in range(3) for v in sorted(both)]
    arrivals = {(0, "uav2"): 0.28, (0, "uav1"): 0.29, (1, "uav1"): 0.2, (1, "uav2"): 0.25, (2, "uav1"): 0.4,
                (2, "uav2"): 0.45}
    released, steps = _assemble(reports, [arrivals[(r.seq - 1, r.vehicle_id)] for r in reports], both)
    assert released == _in_stamp_order(reports, both) and steps.counters["rejected.late"] == 0
    assert [s.index for s in released] == [0, 1, 2] and released[0].stamp_ns == EPOCH_NS - S // 5


def test_a_vehicle_whose_clock_runs_ahead_does_not_cut_the_others_wait_short() -> None:
    """uav1 sends each step a second early: its report opens step 2 long before the others report for it."""
    three = set(VEHICLES)
    steps = StepAssembler(step_ns=S, max_wait_s=MAX_WAIT_S)
    for vehicle in VEHICLES:
        steps.add(_report(vehicle, 0, 1), 0.0)
    assert [s.index for s in steps.ready(three, 0.5)] == [0]
    steps.add(_report("uav1", S, 2), 0.6)
    steps.add(_report("uav1", 2 * S, 3), 0.6)
    steps.add(_report("uav2", S, 2), 0.9)
    steps.add(_report("uav3", S, 2), 0.95)
    assert [s.index for s in steps.ready(three, 0.95)] == [1]
    assert steps.ready(three, 1.5) == []  # 0.9 s after uav1's report: only one of three, no quorum yet
    steps.add(_report("uav2", 2 * S, 3), 1.9)
    assert steps.ready(three, 2.0) == []  # half of them now: the wait runs from here
    steps.add(_report("uav3", 2 * S, 3), 2.05)
    (two,) = steps.ready(three, 2.05)
    assert len(two.reports) == 3 and steps.counters["rejected.late"] == 0


def test_a_step_is_released_at_the_latest_after_the_hold_without_a_quorum() -> None:
    from gcs.engine.steps import HOLD_WAITS

    three = set(VEHICLES)
    steps = StepAssembler(step_ns=S, max_wait_s=MAX_WAIT_S)
    steps.add(_report("uav1", 0, 1), 0.0)  # the other two are silent, their tokens not yet withdrawn
    assert steps.ready(three, HOLD_WAITS * MAX_WAIT_S - 0.01) == []
    assert [s.index for s in steps.ready(three, HOLD_WAITS * MAX_WAIT_S)] == [0]
