"""Running many closed-loop runs: in this process, in worker processes, or on a Dask cluster.

A run is a pure function of (scenario, planner, seed, duration, motion)
(:func:`benchmarks.urban.run_closed_loop` runs every planner to its budget, with
no deadline), so where it runs changes nothing but the wall time: the records
are identical whatever ``workers`` or cluster.

* ``workers = 1``: one after the other, here;
* ``workers = N``: a pool of N processes (``concurrent.futures``), each
  building the scenario's world once;
* ``dask = ADDRESS``: the jobs go to the Dask scheduler at ADDRESS (the
  optional ``cluster`` extra: ``pip install .[cluster]``), whose workers import
  this package; results come back in job order.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from functools import lru_cache

import msgspec

from benchmarks.urban import RunRecord, run_closed_loop
from gcs.config import Scenario

__all__ = ["RunJob", "run_job", "run_jobs", "with_estimator", "DaskUnavailable"]


class DaskUnavailable(RuntimeError):
    """``--dask`` was asked for, but the ``cluster`` extra is not installed or the scheduler cannot be reached."""


@dataclass(frozen=True)
class RunJob:
    """One closed-loop run: the scenario (shipped name or .toml path) and what varies."""

    scenario: str
    planner: str
    seed: int
    duration_s: float | None = None
    motion: str | None = None
    stall: int | None | str = "scenario"
    timed: bool = True
    estimator: str | None = None
    """``[estimator] kind`` in place of the scenario's (None: the scenario's)."""


@lru_cache(maxsize=8)
def _scenario_and_world(scenario: str, thread: int):
    """The scenario and its world, one per thread: the world's memos (its sight table) are filled as
    runs ask, and are not made to be filled by two threads at once (a Dask worker runs jobs in threads)."""
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    loaded = load_scenario(scenario)
    return loaded, build_world(loaded)


def with_estimator(scenario: Scenario, kind: str) -> Scenario:
    """``scenario`` with ``[estimator] kind = kind``, its other estimator settings kept."""
    return msgspec.structs.replace(scenario, estimator=msgspec.structs.replace(scenario.estimator, kind=kind))


def run_job(job: RunJob) -> RunRecord:
    """Run one job (the world is built once per thread and scenario)."""
    import time

    scenario, world = _scenario_and_world(job.scenario, threading.get_ident())
    if job.estimator is not None:
        scenario = with_estimator(scenario, job.estimator)
    return run_closed_loop(scenario, world, job.planner, job.seed, duration_s=job.duration_s, motion=job.motion,
                           stall=job.stall, clock=time.perf_counter if job.timed else None)


def run_jobs(jobs: Sequence[RunJob], workers: int = 1, dask: str | None = None,
             done: Callable[[RunJob, RunRecord], None] | None = None) -> list[RunRecord]:
    """Every job's record, in job order; ``done`` is called as each finishes (in the order they finish)."""
    report = done or (lambda _job, _record: None)
    if dask is not None:
        return _on_dask(jobs, dask, report)
    if workers <= 1 or len(jobs) <= 1:
        records = []
        for job in jobs:
            records.append(run_job(job))
            report(job, records[-1])
        return records
    with ProcessPoolExecutor(max_workers=min(workers, len(jobs))) as pool:
        futures = [pool.submit(run_job, job) for job in jobs]
        try:
            return list(_collect(jobs, futures, report))
        except BaseException:  # Ctrl-C (the workers have it too): the jobs not started are not run
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def _collect(jobs: Sequence[RunJob], futures, report) -> Iterable[RunRecord]:
    from concurrent.futures import as_completed

    index = {future: i for i, future in enumerate(futures)}
    records: list[RunRecord | None] = [None] * len(futures)
    for future in as_completed(futures):
        i = index[future]
        records[i] = future.result()
        report(jobs[i], records[i])
    return records


def _on_dask(jobs: Sequence[RunJob], address: str, report) -> list[RunRecord]:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise DaskUnavailable("--dask needs the cluster extra: pip install 'uav-tracking-gcs[cluster]'") from None
    try:
        client = Client(address, timeout="10s")
    except (OSError, TimeoutError, ValueError) as error:
        raise DaskUnavailable(f"--dask {address}: cannot reach the scheduler ({error})") from None
    try:
        futures = client.map(run_job, list(jobs), pure=False)
        index = {future.key: i for i, future in enumerate(futures)}
        records: list[RunRecord | None] = [None] * len(futures)
        for future in as_completed(futures):
            i = index[future.key]
            records[i] = future.result()
            report(jobs[i], records[i])
        return records
    finally:
        client.close()


def default_workers() -> int:
    """One worker per CPU this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
