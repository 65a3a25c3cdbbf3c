"""Planning beside the daemon's loop: one worker thread, the newest step wins.

Planning a step (the visibility regions of the k+1..k+n predictions, then the
GA or another planner) takes tens to hundreds of milliseconds; fusing a step
takes well under one. Run on the loop thread, every plan holds up the reports,
tracks and queries behind it. So the loop fuses and publishes every step's track
at once and hands the planning to :class:`PlannerWorker`:

* a **mailbox of one**: :meth:`PlannerWorker.submit` replaces a job the worker
  has not started yet (counted as ``superseded``). A plan made from older data
  than the newest fused step is worth nothing once the newer one exists, so the
  worker never queues behind itself;
* the worker runs :func:`gcs.core.tracker.plan` (pure) and posts a
  :class:`PlanOutcome`; the loop takes finished outcomes with
  :meth:`PlannerWorker.take` and applies them (warm-start memory, commands,
  ``PlanCommand``), so every side effect stays on the loop thread;
* the random generator is used only by the worker, one job at a time.

``threaded=False`` runs each job inside :meth:`PlannerWorker.submit`, for
callers that want the plan before they go on (tests, deterministic runs).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gcs.core.filters.prediction import HorizonPrediction
from gcs.core.kinematics import VehicleState
from gcs.core.planners.problem import PlanResult
from gcs.core.tracker import TrackerConfig, TrackerState, plan

__all__ = ["PlanJob", "PlanOutcome", "PlannerWorker"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlanJob:
    """Everything one plan needs, captured on the loop thread when its step was fused.

    Attributes
    ----------
    index, stamp_ns : int
        The decision step the plan is for.
    active : tuple of str
        The vehicles planned (the rows of ``vehicles`` and of the plan).
    config : TrackerConfig
        The tracker for those vehicles.
    state : TrackerState
        The fused estimate, the warm start and the turn rates being flown.
    vehicles : VehicleState
        The vehicles' states at ``stamp_ns``.
    predicted : HorizonPrediction
        The k+1..k+n prediction already published with the track.
    clock_scale : float
        The planner's clock is the worker's clock times this (data time per wall
        second over the share of the step the planner may use; see
        ``Daemon._clock_scale``): its deadline is in data time.
    submitted_s : float
        Loop clock when the job was handed over.
    """

    index: int
    stamp_ns: int
    active: tuple[str, ...]
    config: TrackerConfig
    state: TrackerState
    vehicles: VehicleState
    predicted: HorizonPrediction
    clock_scale: float
    submitted_s: float


@dataclass(frozen=True)
class PlanOutcome:
    """A finished job: the new tracker state and first turn rates, or the error that stopped it.

    ``started_s - job.submitted_s`` is the time the job waited for the worker
    (busy with the previous plan); ``finished_s - started_s`` is the planning
    time (visibility regions and solve). Times are the loop's clock, and
    ``finished_ns`` is ``time.time_ns`` at the end (to compare with other processes).
    """

    job: PlanJob
    state: TrackerState | None
    turn_rates: np.ndarray | None
    result: PlanResult | None
    started_s: float
    finished_s: float
    finished_ns: int
    error: str | None = None

    @property
    def waited_s(self) -> float:
        return self.started_s - self.job.submitted_s

    @property
    def planning_s(self) -> float:
        return self.finished_s - self.started_s

    @property
    def solve_s(self) -> float | None:
        """The planner's own solve time in wall seconds (planning less the visibility regions)."""
        return None if self.result is None else self.result.elapsed_s / self.job.clock_scale


class PlannerWorker:
    """Runs :class:`PlanJob` s one at a time on a thread of its own; see the module docstring."""

    def __init__(self, rng: np.random.Generator, clock: Callable[[], float], threaded: bool = True) -> None:
        self.rng, self.clock, self.threaded = rng, clock, threaded
        self.superseded = 0
        self._pending: PlanJob | None = None
        self._running = False
        self._done: list[PlanOutcome] = []
        self._closing = False
        self._wakeup = threading.Condition()
        self._thread: threading.Thread | None = None
        if threaded:
            self._thread = threading.Thread(target=self._work, name="gcs-planner", daemon=True)
            self._thread.start()

    def submit(self, job: PlanJob) -> None:
        """Hand over a job; it replaces one still waiting (the newest step wins)."""
        if not self.threaded:
            self._done.append(self._run(job))
            return
        with self._wakeup:
            if self._pending is not None:
                self.superseded += 1
            self._pending = job
            self._wakeup.notify()

    def take(self) -> list[PlanOutcome]:
        """The outcomes finished since the last call, oldest first."""
        with self._wakeup:
            done, self._done = self._done, []
        return done

    @property
    def busy(self) -> bool:
        """A job is waiting or running."""
        with self._wakeup:
            return self._running or self._pending is not None

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop the worker after the job it is running (idempotent); waiting jobs are dropped."""
        with self._wakeup:
            self._closing = True
            self._pending = None
            self._wakeup.notify()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout_s)
            if self._thread.is_alive():
                log.warning("the planner thread did not stop within %.0f s", timeout_s)

    def _work(self) -> None:
        while True:
            with self._wakeup:
                while self._pending is None and not self._closing:
                    self._wakeup.wait()
                if self._closing:
                    return
                job, self._pending, self._running = self._pending, None, True
            outcome = self._run(job)
            with self._wakeup:
                self._done.append(outcome)
                self._running = False

    def _run(self, job: PlanJob) -> PlanOutcome:
        started, clock, scale = self.clock(), self.clock, job.clock_scale
        try:
            state, turn_rates, diagnostics = plan(job.config, job.state, job.vehicles, self.rng,
                                                  now=lambda: clock() * scale, predicted=job.predicted)
        except Exception as error:  # a bug in one plan must not stop planning
            log.exception("planning step %d failed; continuing", job.index)
            return PlanOutcome(job, None, None, None, started, self.clock(), time.time_ns(),
                               error=f"{type(error).__name__}: {error}")
        return PlanOutcome(job, state, turn_rates, diagnostics.plan, started, self.clock(), time.time_ns())
