"""Plan runners: how the daemon runs its planner beside the loop, one plan at a time, the newest step winning.

A *planner* is an algorithm (:mod:`gcs.core.planners`); a *plan runner* is where and
when the daemon runs it. Planning a step (the visibility regions of the k+1..k+n
predictions, then the planner's search) takes tens to hundreds of milliseconds;
fusing a step takes a few. Run on the loop, every plan holds up the reports, tracks
and queries behind it. So the loop fuses and publishes every step's track at once and
hands the planning to a plan runner:

* a **mailbox of one**: :meth:`PlanRunner.submit` replaces a job the runner has
  not started yet (counted as ``superseded``). A plan made from older data
  than the newest fused step is worth nothing once the newer one exists, so the
  runner never queues behind itself. The engine goes further: it keeps the
  newest step's planning itself and submits only when the runner is free
  (:class:`~gcs.engine.events.PlannerFree`, at most every
  :func:`~gcs.engine.memory.plan_interval_s`), so a job is built once and carries
  the warm start of the plan just applied;
* the runner plans the job (:func:`run_job`, pure but for the clock of the
  deadline) and the loop takes the finished :class:`~gcs.engine.plan_jobs.PlanOutcome` s
  with :meth:`PlanRunner.take` and hands them to the engine: every side effect stays on
  the loop;
* the random generator belongs to the runner and serves one job at a time.

Three plan runners share that interface (``gcs run --plan-in``):

``process`` (the daemon's default, :class:`gcs.daemon.plan_process.ProcessPlanRunner`)
    A child process with its own tracker, world and generator. Python runs one
    thread at a time in a process, so a planning *thread* takes the interpreter
    from the loop for as long as it computes; a process does not.
``thread`` (:class:`ThreadPlanRunner`)
    A thread of the daemon's process: no start-up cost, shares the interpreter.
``inline`` (:class:`InlinePlanRunner`)
    Plans inside :meth:`~PlanRunner.submit`, before the loop goes on (deterministic).

:func:`gcs.daemon.plan_runner_start.start_plan_runner` starts the one a name gives.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import numpy as np

from gcs.core.tracker import TrackerConfig
from gcs.engine.plan_jobs import PlanJob, PlanOutcome, plan_job

__all__ = ["PLAN_RUNNERS", "PLAN_PROCESS_NICENESS", "START_TIMEOUT_S", "run_job", "PlanRunner", "InlinePlanRunner",
           "ThreadPlanRunner"]

log = logging.getLogger(__name__)

PLAN_RUNNERS = ("process", "thread", "inline")
PLAN_PROCESS_NICENESS = 5
"""How much lower the plan process's scheduling priority is than the daemon's, by default.

Two things pull in opposite directions. The loop (reports, tracks, commands)
should not wait for a CPU while plans are made; the planner's search has a
wall-clock deadline, and what it does not get by then is lost to the plan.
Measured on 2 cores: ``gcs-bench daemon`` (the planner busy all the time) gave a
report-to-command p99 at 5,000 reports/s of 35-38 ms with the planner 5 lower and
7-38 ms with it 19 lower; but in the closed loop against three simulated vehicle
processes (``tests/e2e/test_daemon_closed_loop.py``) the target RMSE was 8.4, 9.6 and
9.1 m at 5 (9.4 m in process) and 10.8, 12.0, 19.5 and 20.1 m at 19: starved of CPU
by the simulators, the search stopped early. The plans are what the ground station
is for, so 5 (about a quarter of the CPU of a busy program at the default priority);
``gcs run --planner-nice 19`` gives the loop the machine when reports flood in."""
START_TIMEOUT_S = 60.0
"""How long a planner process may take to import, build its tracker and say it is ready."""


def run_job(job: PlanJob, config: TrackerConfig, rng: np.random.Generator) -> PlanOutcome:
    """Plan one job with the tracker for its vehicles; an exception becomes the outcome's ``error``."""
    started, scale = time.monotonic(), job.clock_scale

    def clock() -> float:  # the planner's deadline is in data time
        return time.monotonic() * scale

    try:
        state, turn_rates, result = plan_job(job, config, rng, clock)
    except Exception as error:  # a bug in one plan must not stop planning
        log.exception("planning step %d failed; continuing", job.index)
        return PlanOutcome(job, None, None, None, started, time.monotonic(), time.time_ns(),
                           error=f"{type(error).__name__}: {error}")
    return PlanOutcome(job, state, turn_rates, result, started, time.monotonic(), time.time_ns())


class PlanRunner:
    """What the daemon's loop sees of a plan runner (see the module docstring)."""

    superseded: int = 0

    def submit(self, job: PlanJob) -> None:
        """Hand over a job; it replaces one still waiting (the newest step wins)."""
        raise NotImplementedError

    def take(self) -> list[PlanOutcome]:
        """The outcomes finished since the last call, oldest first."""
        raise NotImplementedError

    @property
    def busy(self) -> bool:
        """A job is waiting or being planned."""
        raise NotImplementedError

    @property
    def planning(self) -> bool:
        """A job is being planned (one submitted now waits for it, replacing any job still waiting,
        e.g. while the planner process starts)."""
        raise NotImplementedError

    def finished(self) -> bool:
        """An outcome is ready for :meth:`take` (cheap: the loop asks while it waits for input)."""
        raise NotImplementedError

    def close(self) -> None:
        """Stop after the job being planned (idempotent); a waiting job is dropped."""


class InlinePlanRunner(PlanRunner):
    """Plans in :meth:`submit` (the loop waits for it)."""

    def __init__(self, configs: Callable[[tuple[int, ...]], TrackerConfig], rng: np.random.Generator) -> None:
        self.configs, self.rng = configs, rng
        self._done: list[PlanOutcome] = []

    def submit(self, job: PlanJob) -> None:
        self._done.append(run_job(job, self.configs(job.indices), self.rng))

    def take(self) -> list[PlanOutcome]:
        done, self._done = self._done, []
        return done

    @property
    def busy(self) -> bool:
        return False

    @property
    def planning(self) -> bool:
        return False

    def finished(self) -> bool:
        return bool(self._done)


class ThreadPlanRunner(PlanRunner):
    """Plans on a thread of its own, one job at a time."""

    def __init__(self, configs: Callable[[tuple[int, ...]], TrackerConfig], rng: np.random.Generator) -> None:
        self.configs, self.rng = configs, rng
        self.superseded = 0
        self._pending: PlanJob | None = None
        self._running = False
        self._done: list[PlanOutcome] = []
        self._closing = False
        self._wakeup = threading.Condition()
        self._thread = threading.Thread(target=self._work, name="gcs-planner", daemon=True)
        self._thread.start()

    def submit(self, job: PlanJob) -> None:
        with self._wakeup:
            if self._pending is not None:
                self.superseded += 1
            self._pending = job
            self._wakeup.notify()

    def take(self) -> list[PlanOutcome]:
        with self._wakeup:
            done, self._done = self._done, []
        return done

    @property
    def busy(self) -> bool:
        with self._wakeup:
            return self._running or self._pending is not None

    @property
    def planning(self) -> bool:
        with self._wakeup:
            return self._running

    def finished(self) -> bool:
        return bool(self._done)  # a list's truth is read atomically; take() holds the lock to swap it

    def close(self, timeout_s: float = 10.0) -> None:
        with self._wakeup:
            self._closing, self._pending = True, None
            self._wakeup.notify()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout_s)
            if self._thread.is_alive():
                log.warning("the planning thread did not stop within %.0f s", timeout_s)

    def _work(self) -> None:
        while True:
            with self._wakeup:
                while self._pending is None and not self._closing:
                    self._wakeup.wait()
                job = self._pending
                if self._closing or job is None:
                    return
                self._pending, self._running = None, True
            outcome = run_job(job, self.configs(job.indices), self.rng)
            with self._wakeup:
                self._done.append(outcome)
                self._running = False
