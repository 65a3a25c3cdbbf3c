"""Simulated vehicles that wait for the daemon's plans fly every decision step's plan from that step on."""

from __future__ import annotations

import threading
from contextlib import ExitStack

from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from tests.integration.sim_harness import SCENARIO, WORLD, options, running_vehicles, wait_until
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, daemon_ports

RATE = 20.0
"""Fast enough that a plan can come after the next step's reports when nobody waits."""
S = 1_000_000_000


def test_with_wait_for_plans_every_step_is_planned_before_the_vehicles_fly_past_it() -> None:
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(
        zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()),
        mavlink=dict.fromkeys((v.id for v in SCENARIO.vehicles), ANY_UDP), plan_runner="thread"))
    daemon.open()
    endpoint, port = daemon_ports(daemon)
    thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
    thread.start()
    with ExitStack() as stack:
        stack.callback(lambda: (daemon.stop(), thread.join(timeout=15)))
        runner = stack.enter_context(running_vehicles(options(
            port, rate=RATE, zenoh=ZenohSettings(connect=(endpoint,)), epoch_ns=100 * S, wait_for_subscriber_s=5,
            wait_for_plans=True, duration_s=40.0)))
        wait_until(lambda: runner.summary.steps >= 800, 60, "40 s flown")
        summary = runner.summary
        plans = sorted({p.stamp_ns for p in daemon.plans})
        records = [r.stamp_ns for r in daemon.records]
    assert plans, "the daemon never planned"
    assert summary.plan_held_steps > 0 and summary.plan_waits_timed_out == 0, summary
    # Until the vehicles have heard the first plan they do not wait, and fly on while it is made (the planner's
    # first job is its slowest): a step or two may be fused only there. From then on every step is planned.
    settled = plans[2]
    assert [p for p in plans if p >= settled] == [s for s in records if settled <= s <= plans[-1]]
    assert len(plans) >= 20  # the first track comes some 10 s into the 40
