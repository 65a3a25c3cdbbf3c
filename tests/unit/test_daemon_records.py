"""Step records are emitted in order, each scored against the simulator's truth once it is in."""

from __future__ import annotations

import math

from gcs.engine.records import MAX_TRUTHS, TRUTH_WAIT_S, StepRecord, StepScorer, keep_newest

S = 1_000_000_000


class _Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def _record(index: int, xy=(10.0, 20.0)) -> StepRecord:
    return StepRecord(index, index * S, {"uav1": True}, xy, None, ("uav1",), 0)


def test_a_record_waits_for_its_truth_and_is_scored_against_it() -> None:
    clock, emitted = _Clock(), []
    scorer = StepScorer(S, clock, emitted.append)
    scorer.add_truth(0, (0.0, 0.0))  # a truth source exists, older than the step
    scorer.add(_record(1))
    assert emitted == []  # its truth (stamp 1 s) is not in yet
    scorer.add_truth(1 * S, (13.0, 24.0))
    scorer.score(flush=False)
    assert [r.index for r in emitted] == [1] and math.isclose(emitted[0].error_m, 5.0)
    assert scorer.records == emitted


def test_without_truth_in_time_the_record_goes_unscored_and_order_is_kept() -> None:
    clock, emitted = _Clock(), []
    scorer = StepScorer(S, clock, emitted.append)
    scorer.add_truth(0, (0.0, 0.0))
    scorer.add(_record(1))
    scorer.add(_record(2))
    clock.now += TRUTH_WAIT_S + 0.01
    scorer.score(flush=False)
    assert [r.index for r in emitted] == [1, 2] and all(r.error_m is None for r in emitted)


def test_with_no_truth_source_nothing_waits_and_a_truth_a_tenth_of_a_step_off_counts() -> None:
    emitted = []
    scorer = StepScorer(S, _Clock(), emitted.append)
    scorer.add(_record(1))
    assert [r.error_m for r in emitted] == [None]
    scorer.add_truth(2 * S + S // 20, (10.0, 23.0))  # 50 ms off the step's stamp
    scorer.add(_record(2))
    assert math.isclose(emitted[-1].error_m, 3.0)
    assert scorer.truth_near(3 * S) is None


def test_memory_is_bounded() -> None:
    scorer = StepScorer(S, _Clock())
    for k in range(MAX_TRUTHS + 10):
        scorer.add_truth(k * S, (0.0, 0.0))
    assert len(scorer.truth) == MAX_TRUTHS and min(scorer.truth) == 10 * S
    records = list(range(11))
    keep_newest(records, limit=10)
    assert records == list(range(5, 11))


def test_many_targets_are_scored_by_gospa_against_every_truth_and_name_the_targets_tracked() -> None:
    """Two tracks, three cars: one track 3-4-5 off car ``a``, one 6-8-10 off ``b``, ``c`` untracked. GOSPA
    (c = 100 m, p = 2, alpha = 2) is sqrt(5^2 + 10^2 + 100^2 / 2) = sqrt(5125)."""
    from gcs.daemon.demo import summarise
    from gcs.engine.records import GOSPA_CUTOFF_M

    clock, emitted = _Clock(), []
    scorer = StepScorer(S, clock, emitted.append)
    scorer.add_truth(0, (0.0, 0.0), "a")  # a truth source exists, older than the step
    record = StepRecord(1, S, {"uav1": True}, None, None, ("uav1",), 0, tracks_xy=((3.0, 4.0), (506.0, 8.0)))
    scorer.add(record)
    assert emitted == []  # the truths at 1 s are not in yet
    for name, xy in (("a", (0.0, 0.0)), ("b", (500.0, 0.0)), ("c", (0.0, 900.0))):
        scorer.add_truth(S, xy, name)
        scorer.score(flush=False)
        assert emitted == []  # more truths at 1 s may follow: it waits for a later stamp's
    scorer.add_truth(2 * S, (0.0, 0.0), "a")  # a later stamp: every truth at 1 s is in
    scorer.score(flush=False)
    assert GOSPA_CUTOFF_M == 100.0
    assert [r.index for r in emitted] == [1] and math.isclose(emitted[0].gospa_m, math.sqrt(5125.0))
    assert emitted[0].tracked == ("a", "b") and emitted[0].error_m is None
    summary = summarise(emitted, [], ["uav1"], ["a", "b", "c"])
    assert summary["tracked_steps_per_target"] == {"a": 1, "b": 1, "c": 0}
    assert math.isclose(summary["gospa_m_mean"], math.sqrt(5125.0)) and summary["tracks_last_step"] == 2
    assert "gospa_m_mean" not in summarise([_record(1)], [], ["uav1"])  # one target: no many-target figures
