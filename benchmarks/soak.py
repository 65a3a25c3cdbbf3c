"""``gcs-bench soak``: the whole ground station for a long simulated run with random faults, accounted for.

Processes on 127.0.0.1, as in the field: a ``gcs router``; the daemon
(``gcs run``, a Zenoh client of the router, MAVLink per vehicle group); the
vehicles (``sim-vehicles run --lockstep``, a few vehicles per process, clients
of the router, all on one simulation clock, which a process that falls behind
holds back for all: :mod:`sim_vehicles.lockstep`) whose MAVLink goes through a
:class:`~sim_vehicles.radio_link.UdpRelay` each; and this process, an **observer**
that subscribes to everything the daemon consumes (through the same router,
so it sees exactly what is on the wire) and injects faults at random
(exponential gaps, mean ``fault_every_s`` of wall time):

* ``kill``: SIGKILL a vehicle process (one whose vehicles are on the wire, and
  never the last such: that kill is a burst of bad samples instead); it is
  started again 1-4 s later and
  joins the clock (``--start-at`` in the past: its target is moved to the
  running vehicles' time before its vehicles report);
* ``silence``: mute a process's MAVLink relay for 2-8 s;
* ``inject``: a burst of bad samples (:data:`~benchmarks.faults.INJECTIONS`).

The vehicle processes start their clocks together once every one is up, however
long the machine takes to start them (:mod:`benchmarks.soak_fleet`), so the
run flies its whole duration on a loaded machine too, only more slowly; a run
in which no vehicle report reached the wire ends in an error, not in a report.
At the end the vehicles stop, the daemon drains, and the report compares the
samples on the wire (**published**: the vehicles' and the injected ones) with
what the daemon **received** (accepted, or rejected by a counted reason):
``lost`` must be zero. The **late share** is the vehicles' reports the daemon
took in after their decision step had closed (``rejected.late``, the reports
injected late on purpose taken off), out of the vehicles' reports it accepted.
**Crashes** are processes that died unasked (the
daemon, the router, a vehicle not killed on purpose) and planner restarts.
**Memory** is the daemon's resident set (and its planner process's) at 10%
of the simulated duration and at the end.
"""

from __future__ import annotations

import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zenoh

from gcs.adapters.zenoh_session import ZenohSettings, open_session
from benchmarks.daemon import _load_average, machine_note
from benchmarks.faults import Injector
from sim_vehicles.radio_link import UdpRelay
from benchmarks.soak_fleet import SoakFleet, planner_rss_mb, rss_mb, scenario_file
from benchmarks.soak_report import POST_INGEST, build_report, format_report, received, write_json
from gcs.cli_errors import INTERRUPTED_STATUS
from protocols.keys import navs_selector, reports_selector, scenarios_selector, truth_selector
from protocols.messages import DaemonStatus

__all__ = ["SoakOptions", "run_soak", "format_report", "write_json", "scenario_file", "POST_INGEST"]

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class SoakOptions:
    """What to run: ``vehicles`` in ``processes`` processes for ``duration_s`` simulated seconds at ``rate``."""

    scenario: str = "wang2012_urban"
    vehicles: int = 10
    processes: int = 5
    duration_s: float = 1800.0
    rate: float = 20.0
    seed: int = 0
    fault_every_s: float = 3.0
    planner: str | None = None


def run_soak(options: SoakOptions, command: str = "", progress: Callable[[str], None] | None = None,
             workdir: Path | None = None) -> dict:
    """Run one soak (see the module docstring) and return its report."""
    say = progress or (lambda _msg: None)
    workdir = Path(tempfile.mkdtemp(prefix="gcs-soak-")) if workdir is None else workdir
    workdir.mkdir(parents=True, exist_ok=True)
    soak = SoakFleet(options, workdir, say)
    note, load_start, started = machine_note(), _load_average(), time.monotonic()
    memory: list[tuple[float, float | None, float | None]] = []
    router = daemon = None
    session = None
    try:
        router = soak.start_router()
        session = open_session(ZenohSettings(mode="client", connect=(soak.router_endpoint,)))
        injector = Injector(session, "gcs", np.random.default_rng(options.seed + 1), soak.scenario.time.step_s)
        on_sample = soak.observe(injector)
        for selector in (reports_selector(), navs_selector(), truth_selector(), scenarios_selector()):
            session.declare_subscriber(selector, on_sample)
        soak.relays = [UdpRelay() for _ in soak.groups]
        daemon = soak.start_daemon()
        if soak.status(session, 90.0) is None:
            raise RuntimeError(f"the daemon did not answer (see {workdir / 'daemon.log'})")
        for index in range(len(soak.groups)):
            soak.start_vehicles(index)
        start_at = soak.wait_until_up(session)  # their clocks start together now
        end_at = start_at + options.duration_s / options.rate
        say(f"{options.vehicles} vehicles in {len(soak.groups)} processes, {options.duration_s:g} simulated s at "
            f"{options.rate:g}x: about {end_at - time.time():.0f} s; logs in {workdir}")
        restarts: list[tuple[float, int]] = []
        unmutes: list[tuple[float, int]] = []
        margin = min(5.0, 0.15 * (end_at - start_at))  # no faults while starting up or finishing
        next_fault = start_at + margin + float(soak.rng.exponential(options.fault_every_s))
        next_sample, baseline_at = time.monotonic(), start_at + 0.1 * (end_at - start_at)
        while True:
            now, wall = time.monotonic(), time.time()
            if daemon.poll() is not None:
                soak.crashes["daemon"] += 1
                raise RuntimeError(f"the daemon died (exit {daemon.returncode}; see {workdir / 'daemon.log'})")
            if router.poll() is not None:
                soak.crashes["router"] += 1
                raise RuntimeError(f"the router died (exit {router.returncode})")
            for index, process in enumerate(soak.processes):
                if process is not None and index not in soak.killed and process.poll() not in (None, 0):
                    soak.crashes["vehicle_processes"] += 1
                    say(f"vehicle process {index} died by itself (exit {process.returncode})")
                    soak.processes[index] = None
            for due, index in [item for item in unmutes if item[0] <= now]:
                soak.relays[index].muted = False
                unmutes.remove((due, index))
            closing = wall > end_at - margin / 2
            for due, index in [item for item in restarts if item[0] <= now or closing]:
                restarts.remove((due, index))
                if not closing:
                    soak.start_vehicles(index, soak.clock_start(injector, start_at))
                    soak.faults["restarts"] += 1
            if start_at + margin < wall < end_at - margin and wall >= next_fault:
                soak.fault(injector, now, restarts, unmutes)
                next_fault = wall + float(soak.rng.exponential(options.fault_every_s))
            if now >= next_sample:
                memory.append((wall - start_at, rss_mb(daemon.pid), planner_rss_mb(daemon.pid)))
                next_sample = now + 1.0
            if wall > start_at and all(p is None or p.poll() is not None for p in soak.processes) and not restarts:
                break
            time.sleep(0.05)
        for relay in soak.relays:
            relay.muted = False
        if not soak.observed["report"]:
            raise RuntimeError(f"no vehicle report reached the wire: the vehicle processes flew nothing (see "
                               f"{workdir}/vehicles*.log)")
        baseline = next((m for m in memory if m[0] >= baseline_at - start_at), memory[0] if memory else None)
        status = _drain(soak, session, say)
        end = (time.time() - start_at, rss_mb(daemon.pid), planner_rss_mb(daemon.pid))
    finally:
        for process in [*soak.processes, daemon, router]:
            if process is not None and process.poll() is None:
                process.send_signal(2)  # SIGINT: stop as a user would
        exit_codes = {}
        for name, process in (("daemon", daemon), ("router", router)):
            if process is not None:
                try:
                    exit_codes[name] = process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
                    exit_codes[name] = process.wait()
        for process in soak.processes:
            if process is not None:
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
        for relay in soak.relays:
            relay.close()
        if session is not None:
            session.close()
    for name, code in exit_codes.items():
        if code not in (0, INTERRUPTED_STATUS):  # 130: ended by the SIGINT sent above, as after Ctrl-C
            soak.crashes[name] += 1
    return build_report(options, soak, status, dict(injector.counts), memory, baseline, end, exit_codes, command,
                        note, load_start, time.monotonic() - started, workdir)


def _drain(soak: SoakFleet, session: zenoh.Session, say: Callable[[str], None],
           stalled_s: float = 60.0) -> DaemonStatus:
    """The daemon's status once it has taken in every sample observed, or once it has taken in nothing more for
    ``stalled_s`` (a slow machine drains slowly: the wait goes on while the count grows)."""
    deadline, taken_in = time.monotonic() + stalled_s, -1
    while True:
        status = soak.status(session)
        observed = soak.observed_total()
        if status is not None:
            if received(status.counters) >= observed:
                return status
            if received(status.counters) > taken_in:
                deadline, taken_in = time.monotonic() + stalled_s, received(status.counters)
            elif time.monotonic() > deadline:
                return status
        elif time.monotonic() > deadline:
            raise RuntimeError("the daemon's status stopped answering")
        say(f"draining: the daemon took in {received(status.counters) if status else '?'} of {observed}")
        time.sleep(0.5)
