"""The rule by which simulated vehicles wait for the ground station's plans (sim_vehicles/plan_clock.py)."""

from __future__ import annotations

from sim_vehicles.plan_clock import PlanWatch

S = 1_000_000_000
EPOCH = 100 * S
DT = 50_000_000


def test_nothing_is_waited_for_before_the_first_plan() -> None:
    watch = PlanWatch(period_ns=S, epoch_ns=EPOCH)
    assert not watch.behind(EPOCH + 100 * S + DT)


def test_past_the_reports_of_a_step_a_scene_waits_for_that_steps_plan() -> None:
    watch = PlanWatch(period_ns=S, epoch_ns=EPOCH)
    watch.heard(EPOCH + 3 * S)
    assert not watch.behind(EPOCH + 3 * S + DT)  # reports of 3 are out, plan 3 is in: fly on
    assert not watch.behind(EPOCH + 4 * S)  # the reports of 4 are still to go: plan 3 is enough
    assert watch.behind(EPOCH + 4 * S + DT)  # reports of 4 out: wait for plan 4
    assert watch.needed_ns(EPOCH + 4 * S + DT) == EPOCH + 4 * S
    watch.heard(EPOCH + 4 * S)
    assert not watch.behind(EPOCH + 5 * S - DT)


def test_the_newest_plan_counts_whatever_the_order_plans_arrive_in() -> None:
    watch = PlanWatch(period_ns=S // 2, epoch_ns=EPOCH)  # reports at 2 Hz
    for stamp in (5 * S, 7 * S, 6 * S):
        watch.heard(EPOCH + stamp)
    assert watch.newest_ns == EPOCH + 7 * S and watch.plans == 3
    assert not watch.behind(EPOCH + 7 * S + S // 2) and watch.behind(EPOCH + 7 * S + S // 2 + DT)
