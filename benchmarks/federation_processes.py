"""``gcs-bench federation --processes``: the members as real daemons, separate processes over a real Zenoh router.

The processes (:mod:`benchmarks.federation_fleet`): one ``gcs router``, ``members`` daemons
(``gcs run --federation fed --member m<i> --area <strip i>``, each its own team prefix ``m<i>``) and
their simulated teams of ``uavs_per_member`` UAVs (``sim-vehicles run``, real time), all on 127.0.0.1,
on the city of ``multitarget_urban`` (wang2012_urban's) cut in vertical strips. No central daemon.

This process is an **observer**, a client of the same router, subscribed to what each member's daemon
takes in and puts out: its team's reports, its plans, tracks and status, and its ``MemberTracks`` on
``fed/federation/<member>/tracks``. Every figure is a time of arrival here (one clock for all):

* the **decision time** of a step: from the arrival of the step's last report to that of the step's first
  plan (``PlanCommand`` with the step's stamp): ingest, the multi-target scan, the federation's fusion and
  the plan, plus two trips through the router; for a step with nothing to plan for (no target the
  federation gives the member), to the arrival of its ``MemberTracks``. A step is **undecided** when
  neither came; a step fused while the planner was busy with an older one is planned by a newer step's plan
  (the daemon's ``steps_fused_only`` and ``plans_superseded`` counters);
* the **picture time**: from the same last report to the member's ``MemberTracks`` of that step;
* **traffic**: the payload bytes of the member's ``MemberTracks`` per second of the window (the figure the
  federation's goal is about), and of everything else the daemon publishes under its prefix (tracks, plans,
  status);
* **members seen**: from each daemon's own status, the other members whose liveliness token it holds
  (``federation.joined`` less ``federation.left``), and the ``MemberTracks`` it took in (``federation.heard``).

The window: once every member's daemon holds every other's token and has heard from it, the next ``steps``
decision steps (stamps) of the teams' common clock; it ends when every member has published the step after
the window. Then every process is stopped with SIGINT, as a user stops it.
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zenoh

from benchmarks.federation import areas
from benchmarks.federation_fleet import FEDERATION, Fleet, member_scenario
from gcs.adapters.zenoh_session import ZenohSettings, open_session
from gcs.cli_errors import INTERRUPTED_STATUS
from protocols.codec import decode
from protocols.federation import MemberTracks
from protocols.keys import member_tracks_selector, plans_selector, reports_selector, status_key, tracks_selector
from protocols.messages import PlanCommand, SensorReport
from protocols.status import DaemonStatus

__all__ = ["ProcessesConfig", "run_processes", "SCENARIO", "STARTUP_TIMEOUT_S"]

SCENARIO = "multitarget_urban"
NS_PER_S = 1_000_000_000
STARTUP_TIMEOUT_S = 300.0
"""Wall seconds the processes may take to come up and find each other (a loaded machine starts Python slowly:
the waits end as soon as they are met, this is only how long before giving up)."""
COUNTERS = ("decisions", "steps_fused_only", "plans_superseded", "steps_released_by_timeout", "rejected.late",
            "errors.decision", "federation.heard", "rejected.federation")


@dataclass(frozen=True)
class ProcessesConfig:
    """One run: ``members`` daemons with ``uavs_per_member`` UAVs each, for ``steps`` decision steps."""

    members: int = 3
    uavs_per_member: int = 3
    steps: int = 120
    fusion: str = "ci"
    range_m: float = 1000.0
    seed: int = 0


class Observer:
    """Arrival times and sizes of what each member's daemon takes in and puts out (module docstring)."""

    def __init__(self, members: list[str]) -> None:
        self.members = members
        self.changed = threading.Condition()
        self.report_at: dict[str, dict[int, float]] = {m: {} for m in members}
        """Per member and stamp: when the step's last report arrived (monotonic seconds)."""
        self.plan_at: dict[str, dict[int, float]] = {m: {} for m in members}
        """Per member and stamp: when the step's first plan arrived."""
        self.shared: dict[str, dict[int, tuple[float, int]]] = {m: {} for m in members}
        """Per member and stamp: when its ``MemberTracks`` arrived, and its payload bytes."""
        self.team_bytes: dict[str, int] = dict.fromkeys(members, 0)
        self.status: dict[str, DaemonStatus] = {}
        self.newest: dict[str, int] = {}
        """Per member: the stamp of its newest ``MemberTracks``."""
        self.subscribers: list = []

    def subscribe(self, session: zenoh.Session) -> None:
        """Declare the subscribers (kept here until the session closes)."""
        subscribers = [session.declare_subscriber(member_tracks_selector(FEDERATION), self._shared)]
        for member in self.members:
            subscribers += [
                session.declare_subscriber(reports_selector(member), self._stamped(member, SensorReport, self.report_at,
                                                                                   last=True)),
                session.declare_subscriber(plans_selector(member), self._stamped(member, PlanCommand, self.plan_at)),
                session.declare_subscriber(tracks_selector(member), self._counted(member)),
                session.declare_subscriber(status_key(member), self._status(member))]
        self.subscribers = subscribers

    def _stamped(self, member: str, kind, times: dict[str, dict[int, float]], last: bool = False):
        def on_sample(sample: zenoh.Sample) -> None:
            now = time.monotonic()
            payload = sample.payload.to_bytes()
            stamp = decode(payload, str(sample.encoding), kind).stamp_ns
            with self.changed:
                if last or stamp not in times[member]:
                    times[member][stamp] = now
                if kind is PlanCommand:
                    self.team_bytes[member] += len(payload)
        return on_sample

    def _counted(self, member: str):
        def on_sample(sample: zenoh.Sample) -> None:
            with self.changed:
                self.team_bytes[member] += len(sample.payload)
        return on_sample

    def _status(self, member: str):
        def on_sample(sample: zenoh.Sample) -> None:
            payload = sample.payload.to_bytes()
            status = decode(payload, str(sample.encoding), DaemonStatus)
            with self.changed:
                self.team_bytes[member] += len(payload)
                self.status[member] = status
                self.changed.notify_all()
        return on_sample

    def _shared(self, sample: zenoh.Sample) -> None:
        now = time.monotonic()
        payload = sample.payload.to_bytes()
        message = decode(payload, str(sample.encoding), MemberTracks)
        with self.changed:
            if message.member_id in self.shared:
                self.shared[message.member_id][message.stamp_ns] = (now, len(payload))
                self.newest[message.member_id] = max(message.stamp_ns, self.newest.get(message.member_id, 0))
            self.changed.notify_all()

    def others_seen(self, member: str) -> int:
        """How many other members ``member``'s daemon holds the token of, by its newest status (-1: no status)."""
        status = self.status.get(member)
        if status is None:
            return -1
        return status.counters.get("federation.joined", 0) - status.counters.get("federation.left", 0)

    def all_met(self) -> bool:
        """Every member's daemon holds every other's token, has heard from them, and has published its picture."""
        others = len(self.members) - 1
        return all(self.others_seen(m) >= others and m in self.newest
                   and (others == 0 or self.status[m].counters.get("federation.heard", 0) > 0) for m in self.members)

    def wait(self, done: Callable[[], bool], what: str, timeout_s: float, exited: Callable[[], dict[str, int]]) -> None:
        """Wait until ``done()`` (checked at each status or picture that arrives); RuntimeError when a process
        exits or ``timeout_s`` passes first."""
        deadline = time.monotonic() + timeout_s
        with self.changed:
            while not done():
                if gone := exited():
                    raise RuntimeError(f"waiting for {what}: processes exited {gone}")
                if time.monotonic() > deadline:
                    raise RuntimeError(f"waiting for {what}: not within {timeout_s:g} s")
                self.changed.wait(timeout=1.0)


def run_processes(config: ProcessesConfig, progress: Callable[[str], None] = lambda _: None,
                  workdir: Path | None = None) -> dict:
    """Run the federation as processes (module docstring); the report as a dict
    (:mod:`benchmarks.federation_processes_report`)."""
    from benchmarks.federation_processes_report import build_report
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    workdir = workdir or Path(tempfile.mkdtemp(prefix="federation-processes-"))
    names = [f"m{i}" for i in range(config.members)]
    strips = areas(build_world(load_scenario(SCENARIO)), config.members)
    paths = [workdir / f"{name}.toml" for name in names]
    scenario = [member_scenario(SCENARIO, strip, config.uavs_per_member, config.range_m, path)
                for path, strip in zip(paths, strips)][0]
    step_ns = round(scenario.time.step_s * NS_PER_S)
    observer = Observer(names)
    fleet = Fleet(workdir, config.seed, config.fusion)
    load_start = os.getloadavg()
    session = None
    try:
        endpoint = fleet.start_router(STARTUP_TIMEOUT_S)
        session = open_session(ZenohSettings(mode="client", connect=(endpoint,)))
        observer.subscribe(session)
        logs = [fleet.start_member(name, path, strip) for name, path, strip in zip(names, paths, strips)]
        ports = [fleet.mavlink_port(log, STARTUP_TIMEOUT_S) for log in logs]
        progress(f"{config.members} daemons up; starting their teams")
        epoch_s = int(time.time())
        for name, path, port in zip(names, paths, ports):
            fleet.start_team(name, path, port, epoch_s)
        observer.wait(observer.all_met, "every member to see every other", STARTUP_TIMEOUT_S, fleet.exited)
        with observer.changed:
            first = max(observer.newest.values()) + step_ns
            before = {m: dict(observer.status[m].counters) for m in names}
            team_before = dict(observer.team_bytes)
        started = time.monotonic()
        progress(f"every member sees the others; measuring {config.steps} steps")
        end = first + config.steps * step_ns
        observer.wait(lambda: all(observer.newest.get(m, 0) >= end for m in names),
                      f"every member's step {config.steps} of the window", config.steps * 3 + STARTUP_TIMEOUT_S,
                      fleet.exited)
        wall_s = time.monotonic() - started
        with observer.changed:
            after = {m: dict(observer.status[m].counters) for m in names}
            seen = {m: observer.others_seen(m) for m in names}
            team_s = {m: (observer.team_bytes[m] - team_before[m]) / wall_s for m in names}
    finally:
        if session is not None:
            session.close()
        codes = fleet.stop()
    bad = {name: code for name, code in codes.items() if code not in (0, INTERRUPTED_STATUS)}
    if bad:
        raise RuntimeError(f"processes did not stop cleanly: {bad} (see {workdir})")
    return build_report(config, observer, (first, end, step_ns), before, after, seen, team_s,
                        (load_start, os.getloadavg()), codes, scenario)


def step_figures(observer: Observer, member: str, window: tuple[int, int, int]) -> dict:
    """One member's steps in the window: decision and picture times (ms), the steps it planned, bytes/s."""
    first, end, step_ns = window
    stamps = [k for k in sorted(observer.report_at[member]) if first <= k < end]
    decision, picture, planned = [], [], 0
    for k in stamps:
        reported = observer.report_at[member][k]
        pictured = observer.shared[member].get(k)
        if pictured is not None:
            picture.append(1e3 * (pictured[0] - reported))
        if k in observer.plan_at[member]:
            planned += 1
            decision.append(1e3 * (observer.plan_at[member][k] - reported))
        elif pictured is not None:
            decision.append(picture[-1])
    shared = sum(size for k, (_, size) in observer.shared[member].items() if first <= k < end)
    return {"steps": len(stamps), "planned": planned, "decision_ms": _spread(decision), "picture_ms": _spread(picture),
            "over_step": sum(ms > step_ns / 1e6 for ms in decision), "undecided": len(stamps) - len(decision),
            "federation_bytes_per_s": shared / ((end - first) / NS_PER_S)}


def _spread(values: list[float]) -> dict:
    if not values:
        return {"n": 0, "median": None, "p99": None, "max": None}
    a = np.asarray(values)
    return {"n": len(a), "median": float(np.median(a)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


def counter_deltas(before: dict[str, int], after: dict[str, int]) -> dict[str, int]:
    return {name: after.get(name, 0) - before.get(name, 0) for name in COUNTERS}

