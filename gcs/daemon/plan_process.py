"""The plan runner in a child process (:mod:`gcs.daemon.plan_runners`' ``process``, the daemon's default).

Python runs one thread at a time in a process, so a planning *thread* takes the
interpreter from the daemon's loop for as long as it computes; a child process
does not. The child (:func:`_serve`) builds its own tracker from the scenario and
world and plans the jobs it is sent, one at a time; :class:`ProcessPlanRunner` keeps
the mailbox of one on the daemon's side, starts the child in the background and
starts it again if it dies.
"""

from __future__ import annotations

import gc
import logging
import multiprocessing
import select
import signal
import threading
import time
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess

import numpy as np

from gcs.config import Scenario
from gcs.core.tracker import TrackerConfig
from gcs.core.world import World
from gcs.daemon.plan_runners import PLAN_PROCESS_NICENESS, START_TIMEOUT_S, PlanRunner, run_job
from gcs.engine.plan_jobs import PlanJob, PlanOutcome
from gcs.daemon.niceness import check_niceness, lower_priority
from gcs.engine.tracker_factory import subset_config, tracker_config

__all__ = ["ProcessPlanRunner"]

log = logging.getLogger(__name__)


def _serve(conn, scenario: Scenario, world: World, planner_name: str, seed: int, niceness: int,
           autopilot_turn_rates: bool) -> None:
    """The planner process: build the tracker, then plan each job received until told to stop."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group; the daemon stops us
    lower_priority(niceness)
    try:
        tracker = tracker_config(scenario, world, planner_name, autopilot_turn_rates=autopilot_turn_rates)
    except Exception as error:
        conn.send(("error", f"{type(error).__name__}: {error}"))
        return
    configs: dict[tuple[int, ...], TrackerConfig] = {}
    rng = np.random.default_rng(seed)
    gc.freeze()  # the imports and the world: never garbage, and slow to walk (see gcs.daemon.app.Daemon.run)
    conn.send(("ready", None))
    while True:
        try:
            job = conn.recv()
        except (EOFError, KeyboardInterrupt):  # the daemon is gone, or Ctrl-C reached the whole group
            return
        if job is None:
            return
        config = configs.get(job.indices)
        if config is None:
            config = configs[job.indices] = subset_config(tracker, job.indices)
        outcome = run_job(job, config, rng)
        try:  # the outcome's fields after its job, which the daemon has already
            conn.send((outcome.state, outcome.turn_rates, outcome.result, outcome.started_s, outcome.finished_s,
                       outcome.finished_ns, outcome.error))
        except (BrokenPipeError, EOFError):
            return


class ProcessPlanRunner(PlanRunner):
    """Plans in a child process (spawned, so no thread of the daemon's is copied into it).

    The child builds its own tracker from the scenario and world, seeds its own
    generator, and runs at a lower priority (``niceness``, :data:`PLAN_PROCESS_NICENESS` by default). It is
    started in the background: starting Python and handing it the world takes a
    second or more, which the loop spends fusing (jobs submitted meanwhile wait,
    the newest winning). The mailbox of one is kept here: a job is sent only when
    the child is idle, so the child never plans a step older than the newest one
    waiting. A child that dies is reported and started again.
    """

    def __init__(self, scenario: Scenario, world: World, planner_name: str, seed: int,
                 niceness: int = PLAN_PROCESS_NICENESS, autopilot_turn_rates: bool = False) -> None:
        self._arguments = (scenario, world, planner_name, seed, check_niceness(niceness, "the planner's"),
                           autopilot_turn_rates)
        self.superseded = 0
        self.restarts = 0
        self._in_flight: PlanJob | None = None
        self._pending: PlanJob | None = None
        self._closed = False
        self._begin()

    # ----------------------------------------------------------- the child

    def _begin(self) -> None:
        """Start a child in the background; :meth:`take` notices when it is ready."""
        self._ready = False
        self._conn: Connection | None = None
        self._process: BaseProcess | None = None
        self._poller: select.poll | None = None
        self._poller_conn: Connection | None = None
        self._begin_s = time.monotonic()
        self._launcher = threading.Thread(target=self._launch, name="gcs-planner-start", daemon=True)
        self._launcher.start()

    def _launch(self) -> None:
        context = multiprocessing.get_context("spawn")
        conn, child = context.Pipe()
        process = context.Process(target=_serve, args=(child, *self._arguments), name="gcs-planner", daemon=True)
        process.start()  # blocks until the child has read its arguments
        child.close()  # so that a dead child reads as EOF here
        self._conn, self._process = conn, process

    def _check_ready(self) -> bool:
        """Whether the child said it is ready (then the job waiting is sent); RuntimeError when it
        died or could not build its tracker, or took longer than :data:`START_TIMEOUT_S`."""
        if self._ready:
            return True
        try:
            conn = None if self._launcher.is_alive() else self._conn
            reply = conn.recv() if conn is not None and conn.poll() else None
        except (EOFError, ConnectionResetError):
            raise RuntimeError("the planner process died while starting") from None
        if reply is None:
            if time.monotonic() - self._begin_s > START_TIMEOUT_S:
                raise RuntimeError(f"the planner process did not start within {START_TIMEOUT_S:.0f} s")
            return False
        kind, detail = reply
        if kind != "ready":
            raise RuntimeError(f"the planner process could not build its tracker: {detail}")
        self._ready = True
        self._send_pending()
        return True

    def _readable(self) -> bool:
        """Whether the child has written to the pipe (or closed it): ``select.poll`` on its descriptor,
        registered once per pipe. ``Connection.poll`` builds a selector on every call, which at
        hundreds of steps a second cost the loop tens of microseconds a step."""
        conn = self._pipe()
        if not hasattr(select, "poll"):  # not on Linux or macOS
            return conn.poll()
        if self._poller is None or self._poller_conn is not conn:
            self._poller = select.poll()
            self._poller.register(conn.fileno(), select.POLLIN)
            self._poller_conn = conn
        return bool(self._poller.poll(0))

    def _pipe(self) -> Connection:
        """The pipe to the child (there is one once the child said it is ready)."""
        if self._conn is None:
            raise RuntimeError("the planner process has not started")
        return self._conn

    def _restart(self) -> None:
        log.error("the planner process died (exit code %s)%s; starting it again",
                  None if self._process is None else self._process.exitcode,
                  f" planning step {self._in_flight.index}" if self._in_flight else "")
        self.restarts += 1
        self._in_flight = None
        self._stop(timeout_s=1.0)
        self._begin()

    # ------------------------------------------------------------ the loop

    def submit(self, job: PlanJob) -> None:
        if self._pending is not None:
            self.superseded += 1
        self._pending = job
        if self._in_flight is None and self._check_ready():
            self._send_pending()

    def _send_pending(self) -> None:
        if self._pending is None:
            return
        job, self._pending = self._pending, None
        try:
            self._pipe().send(job)
        except (BrokenPipeError, ConnectionResetError, EOFError):
            self._pending = job
            self._restart()
            return
        self._in_flight = job

    def take(self) -> list[PlanOutcome]:
        done: list[PlanOutcome] = []
        if self._closed or not self._check_ready():
            return done
        try:
            while self._in_flight is not None and self._readable():
                done.append(PlanOutcome(self._in_flight, *self._pipe().recv()))
                self._in_flight = None
                self._send_pending()
        except (EOFError, BrokenPipeError, ConnectionResetError):
            self._restart()
        return done

    @property
    def busy(self) -> bool:
        return self._in_flight is not None or self._pending is not None

    @property
    def planning(self) -> bool:
        return self._in_flight is not None

    def finished(self) -> bool:
        if self._closed or not self._check_ready():  # (once ready, the job waiting has been sent)
            return False
        try:
            return self._in_flight is not None and self._readable()
        except (OSError, EOFError):  # a dead child: take() restarts it
            return True

    def close(self, timeout_s: float = 10.0) -> None:
        if not self._closed:
            self._closed, self._pending = True, None
            self._stop(timeout_s)

    def _stop(self, timeout_s: float) -> None:
        self._launcher.join(timeout_s)
        process, conn = self._process, self._conn
        if process is None or conn is None:
            return
        if process.is_alive():
            try:
                conn.send(None)
            except (BrokenPipeError, OSError):
                pass
            process.join(timeout_s)
        if process.is_alive():
            log.warning("the planner process did not stop within %.0f s; terminating it", timeout_s)
            process.terminate()
            process.join(5.0)
        conn.close()
