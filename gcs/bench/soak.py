"""``gcs bench soak``: the whole ground station for a long simulated run with random faults, accounted for.

Processes on 127.0.0.1, as in the field: a ``gcs router``; the daemon
(``gcs run``, a Zenoh client of the router, MAVLink per vehicle group); the
vehicles (``sim-vehicles run``, a few vehicles per process, clients of the
router, all on one simulation clock) whose MAVLink goes through a
:class:`~gcs.bench.faults.UdpRelay` each; and this process, an **observer**
that subscribes to everything the daemon consumes (through the same router,
so it sees exactly what is on the wire) and injects faults at random
(exponential gaps, mean ``fault_every_s`` of wall time):

* ``kill``: SIGKILL a vehicle process; it is started again 1-4 s later and
  joins the clock (``--start-at`` in the past);
* ``silence``: mute a process's MAVLink relay for 2-8 s;
* ``inject``: a burst of bad samples (:data:`~gcs.bench.faults.INJECTIONS`).

At the end the vehicles stop, the daemon drains, and the report compares the
samples on the wire (**published**: the vehicles' and the injected ones) with
what the daemon **received** (accepted, or rejected by a counted reason):
``lost`` must be zero. **Crashes** are processes that died unasked (the
daemon, the router, a vehicle not killed on purpose) and planner restarts.
**Memory** is the daemon's resident set (and its planner process's) at 10%
of the simulated duration and at the end.
"""

from __future__ import annotations

import json
import select
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import asdict, dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import zenoh

from gcs.adapters.ports import LOCALHOST, free_tcp_port, free_udp_port
from gcs.adapters.zenoh_session import ZenohSettings, open_session, query
from gcs.bench.daemon import _load_average, machine_note
from gcs.bench.faults import Injector, UdpRelay, every_kind
from gcs.bench.urban import with_vehicles
from gcs.scenarios import load_scenario
from protocols.codec import decode
from protocols.keys import navs_selector, reports_selector, status_key, truth_selector
from protocols.messages import DaemonStatus

__all__ = ["SoakOptions", "run_soak", "format_report", "scenario_file", "POST_INGEST"]

NS_PER_S = 1_000_000_000
EPOCH_NS = 1_000_000 * NS_PER_S
POST_INGEST = ("rejected.late", "rejected.diverged")
"""Rejections of reports ingest had accepted (counted twice otherwise)."""


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


def scenario_file(name: str, count: int, directory: Path) -> Path:
    """A scenario file: the shipped (or given) one with vehicles added up to ``count`` (as ``gcs bench urban``)."""
    path = Path(name)
    text = path.read_text() if path.suffix == ".toml" else (resources.files("gcs.scenarios") / f"{name}.toml").read_text()
    base = load_scenario(name)
    if count < len(base.vehicles):
        raise ValueError(f"--vehicles must be at least the scenario's {len(base.vehicles)}")
    blocks = []
    for v in with_vehicles(base, count).vehicles[len(base.vehicles):]:
        blocks.append(f'\n[[vehicles]]\nid = "{v.id}"\nsysid = {v.sysid}\naltitude_m = {v.altitude_m!r}\n'
                      f'speed_mps = {v.speed_mps!r}\nmax_turn_rate_rad_s = {v.max_turn_rate_rad_s!r}\n'
                      f'start_enu_m = [{float(v.start_enu_m[0])!r}, {float(v.start_enu_m[1])!r}]\n'
                      f'start_heading_rad = {float(v.start_heading_rad)!r}\n')
    out = directory / f"soak-{count}.toml"
    out.write_text(text + "".join(blocks))
    load_scenario(out)  # fails here, clearly, if the file is not a valid scenario
    return out


def _rss_mb(pid: int) -> float | None:
    """Resident set of a process (MB), from /proc; None where there is no /proc or the process is gone."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def _planner_rss_mb(pid: int) -> float | None:
    """Resident set of the daemon's largest child process (its planner; the others are multiprocessing's helpers)."""
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as children:
            sizes = [_rss_mb(int(child)) for child in children.read().split()]
    except OSError:
        return None
    return max((size for size in sizes if size is not None), default=None)


class _Soak:
    """The processes, the observer and the fault schedule of one soak run."""

    def __init__(self, options: SoakOptions, workdir: Path, say: Callable[[str], None]) -> None:
        self.options, self.workdir, self.say = options, workdir, say
        self.rng = np.random.default_rng(options.seed)
        self.scenario_path = scenario_file(options.scenario, options.vehicles, workdir)
        self.scenario = load_scenario(self.scenario_path)
        ids = [v.id for v in self.scenario.vehicles]
        self.groups = [ids[i::options.processes] for i in range(min(options.processes, len(ids)))]
        self.router_endpoint = f"tcp/{LOCALHOST}:{free_tcp_port()}"
        self.daemon_ports = [free_udp_port() for _ in self.groups]
        self.relays: list[UdpRelay] = []
        self.observed: Counter = Counter()
        self.crashes: Counter = Counter()
        self.faults: Counter = Counter()
        self.silence_s = 0.0
        self.processes: list[subprocess.Popen | None] = [None] * len(self.groups)
        self.killed: set[int] = set()
        self.newest_stamp_ns = 0
        self._first = [str(kind) for kind in self.rng.permutation(["kill", "silence", "inject"])]
        self.others: list[subprocess.Popen] = []
        self._lock = threading.Lock()

    # ------------------------------------------------------------ processes

    def _spawn(self, name: str, argv: list[str], stdout=subprocess.DEVNULL) -> subprocess.Popen:
        log = open(self.workdir / f"{name}.log", "a")
        try:
            return subprocess.Popen(argv, stdout=stdout, stderr=log, text=True)
        finally:
            log.close()

    def start_router(self) -> subprocess.Popen:
        router = self._spawn("router", [sys.executable, "-m", "gcs.cli", "router", "--zenoh-listen",
                                        self.router_endpoint], stdout=subprocess.PIPE)
        ready, _, _ = select.select([router.stdout], [], [], 60.0)
        if not ready or "router listening" not in router.stdout.readline():
            raise RuntimeError(f"the router did not start (see {self.workdir / 'router.log'})")
        return router

    def start_daemon(self) -> subprocess.Popen:
        vehicles = [f"{v}=udpin:{LOCALHOST}:{port}" for group, port in zip(self.groups, self.daemon_ports)
                    for v in group]
        argv = [sys.executable, "-m", "gcs.cli", "run", "--scenario", str(self.scenario_path), "--seed",
                str(self.options.seed), "--zenoh-mode", "client", "--zenoh-connect", self.router_endpoint,
                *[arg for v in vehicles for arg in ("--vehicle", v)]]
        if self.options.planner:
            argv += ["--planner", self.options.planner]
        return self._spawn("daemon", argv)

    def start_vehicles(self, index: int, start_at: float) -> None:
        only = [arg for v in self.groups[index] for arg in ("--only", v)]
        self.processes[index] = self._spawn(f"vehicles{index}", [
            sys.executable, "-m", "sim_vehicles.cli", "--log-level", "WARNING", "run",
            "--scenario", str(self.scenario_path), *only, "--seed", str(self.options.seed),
            "--rate", str(self.options.rate), "--duration", str(self.options.duration_s),
            "--epoch-ns", str(EPOCH_NS), "--start-at", repr(start_at),
            "--mavlink", f"udpout:{LOCALHOST}:{self.relays[index].port}",
            "--zenoh-mode", "client", "--zenoh-connect", self.router_endpoint,
            "--json", str(self.workdir / f"vehicles{index}.json")])
        self.killed.discard(index)

    def simulation_lag(self) -> dict:
        """From the vehicle processes that ran to the end: physics steps started late (the machine did not
        keep the rate), out of all."""
        late = steps = 0
        for index in range(len(self.groups)):
            path = self.workdir / f"vehicles{index}.json"
            if path.exists():
                summary = json.loads(path.read_text())
                late, steps = late + summary["late_steps"], steps + summary["steps"]
        return {"late_steps": late, "steps": steps}

    # ------------------------------------------------------------- observer

    def observe(self, injector: Injector) -> Callable[[zenoh.Sample], None]:
        def on_sample(sample: zenoh.Sample) -> None:
            key = str(sample.key_expr)
            kind = key.rsplit("/", 1)[-1] if "/vehicle/" in key else "truth"
            with self._lock:
                self.observed[kind] += 1
            stamp = injector.observe(key, sample.payload.to_bytes(), str(sample.encoding))
            if stamp is not None and stamp > self.newest_stamp_ns:
                self.newest_stamp_ns = stamp
        return on_sample

    def clock_start(self, session: zenoh.Session, start_at: float) -> float:
        """The ``--start-at`` that joins the vehicles where their data is now, not where the wall clock says
        they should be (on a machine that cannot keep the rate they run behind it): the newest report the
        daemon has taken in, so that the restarted vehicles' stamps are not older than their last ones there."""
        status = self.status(session, 2.0)
        stamps = [v.last_report_stamp_ns for v in status.vehicles if v.last_report_stamp_ns] if status else []
        newest = max(stamps, default=self.newest_stamp_ns)
        if newest <= EPOCH_NS:
            return start_at
        return time.time() - (newest - EPOCH_NS) / NS_PER_S / self.options.rate

    def status(self, session: zenoh.Session, timeout_s: float = 5.0) -> DaemonStatus | None:
        for sample in query(session, status_key(), timeout_s):
            return decode(sample.payload.to_bytes(), str(sample.encoding), DaemonStatus)
        return None

    # ---------------------------------------------------------------- faults

    def fault(self, injector: Injector, now: float, restarts: list, unmutes: list) -> None:
        """One fault: the first three are one of each kind (in a random order), then at random."""
        kind = self._first.pop() if self._first else self.rng.choice(["kill", "silence", "inject"],
                                                                       p=[0.25, 0.25, 0.5])
        running = [i for i, p in enumerate(self.processes) if p is not None and p.poll() is None]
        if kind == "kill" and running:
            index = int(self.rng.choice(running))
            self.processes[index].kill()
            self.killed.add(index)
            self.faults["kills"] += 1
            restarts.append((now + float(self.rng.uniform(1.0, 4.0)), index))
            self.say(f"killed vehicle process {index} ({', '.join(self.groups[index])})")
        elif kind == "silence":
            quiet = [i for i, relay in enumerate(self.relays) if not relay.muted]
            if quiet:
                index, seconds = int(self.rng.choice(quiet)), float(self.rng.uniform(2.0, 8.0))
                self.relays[index].muted = True
                self.faults["silences"] += 1
                self.silence_s += seconds
                unmutes.append((now + seconds, index))
        else:
            pick = every_kind(self.rng)
            for _ in range(int(self.rng.integers(1, 21))):
                injector.inject(pick())


def run_soak(options: SoakOptions, command: str = "", progress: Callable[[str], None] | None = None,
             workdir: Path | None = None) -> dict:
    """Run one soak (see the module docstring) and return its report."""
    say = progress or (lambda _msg: None)
    workdir = Path(tempfile.mkdtemp(prefix="gcs-soak-")) if workdir is None else workdir
    workdir.mkdir(parents=True, exist_ok=True)
    soak = _Soak(options, workdir, say)
    note, load_start, started = machine_note(), _load_average(), time.monotonic()
    memory: list[tuple[float, float | None, float | None]] = []
    router = daemon = None
    session = None
    try:
        router = soak.start_router()
        session = open_session(ZenohSettings(mode="client", connect=(soak.router_endpoint,)))
        injector = Injector(session, "gcs", np.random.default_rng(options.seed + 1), soak.scenario.time.step_s)
        on_sample = soak.observe(injector)
        for selector in (reports_selector(), navs_selector(), truth_selector()):
            session.declare_subscriber(selector, on_sample)
        soak.relays = [UdpRelay(port) for port in soak.daemon_ports]
        daemon = soak.start_daemon()
        if soak.status(session, 90.0) is None:
            raise RuntimeError(f"the daemon did not answer (see {workdir / 'daemon.log'})")
        start_at = time.time() + 3.0 + 0.5 * len(soak.groups)
        for index in range(len(soak.groups)):
            soak.start_vehicles(index, start_at)
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
                    soak.start_vehicles(index, soak.clock_start(session, start_at))
                    soak.faults["restarts"] += 1
            if start_at + margin < wall < end_at - margin and wall >= next_fault:
                soak.fault(injector, now, restarts, unmutes)
                next_fault = wall + float(soak.rng.exponential(options.fault_every_s))
            if now >= next_sample:
                memory.append((wall - start_at, _rss_mb(daemon.pid), _planner_rss_mb(daemon.pid)))
                next_sample = now + 1.0
            if wall > start_at and all(p is None or p.poll() is not None for p in soak.processes) and not restarts:
                break
            time.sleep(0.05)
        for relay in soak.relays:
            relay.muted = False
        baseline = next((m for m in memory if m[0] >= baseline_at - start_at), memory[0] if memory else None)
        status = _drain(soak, session, say)
        end = (time.time() - start_at, _rss_mb(daemon.pid), _planner_rss_mb(daemon.pid))
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
        if code != 0:
            soak.crashes[name] += 1
    return _report(options, soak, status, injector, memory, baseline, end, exit_codes, command, note, load_start,
                   time.monotonic() - started, workdir)


def _received(counters: dict[str, int]) -> int:
    """Samples the daemon took in: accepted, or rejected by ingest."""
    return sum(v for k, v in counters.items() if k.startswith("accepted.")) + sum(
        v for k, v in counters.items() if k.startswith("rejected.") and k not in POST_INGEST)


def _drain(soak: _Soak, session: zenoh.Session, say: Callable[[str], None], timeout_s: float = 60.0) -> DaemonStatus:
    """The daemon's status once it has taken in every sample observed (or ``timeout_s`` passed)."""
    deadline = time.monotonic() + timeout_s
    while True:
        status = soak.status(session)
        with soak._lock:
            observed = sum(soak.observed.values())
        if status is not None and (_received(status.counters) >= observed or time.monotonic() > deadline):
            return status
        if time.monotonic() > deadline:
            raise RuntimeError("the daemon's status stopped answering")
        say(f"draining: the daemon took in {_received(status.counters) if status else '?'} of {observed}")
        time.sleep(0.5)


def _report(options: SoakOptions, soak: _Soak, status: DaemonStatus, injector: Injector, memory, baseline, end,
            exit_codes: dict, command: str, note: str, load_start: str, wall_s: float, workdir: Path) -> dict:
    counters = dict(status.counters)
    published = dict(soak.observed)
    total = sum(published.values())
    received = _received(counters)
    dropped = {k.removeprefix("rejected."): v for k, v in sorted(counters.items()) if k.startswith("rejected.")}
    crashes = {"daemon": soak.crashes["daemon"], "router": soak.crashes["router"],
               "vehicle_processes": soak.crashes["vehicle_processes"],
               "planner_restarts": counters.get("planner_restarts", 0)}
    rss = [m for m in memory if m[1] is not None]
    return {
        "command": command, "machine": note, "load_average": {"start": load_start, "end": _load_average()},
        "options": asdict(options), "wall_s": wall_s, "workdir": str(workdir),
        "simulated_s": (status.last_track_stamp_ns - EPOCH_NS) / NS_PER_S if status.last_track_stamp_ns else 0.0,
        "published": {**published, "injected": sum(injector.counts.values()), "total": total},
        "received": received,
        "accepted": {k.removeprefix("accepted."): v for k, v in sorted(counters.items()) if k.startswith("accepted.")},
        "used_in_steps": counters.get("accepted.report", 0) - counters.get("rejected.late", 0),
        "dropped": dropped,
        "lost": total - received,
        "crashes": crashes, "crashes_total": sum(crashes.values()), "exit_codes": exit_codes,
        "errors": {k: v for k, v in counters.items() if k.startswith("errors.")},
        "faults": {"kills": soak.faults["kills"], "restarts": soak.faults["restarts"],
                   "silences": soak.faults["silences"], "silence_s": soak.silence_s,
                   "injected": dict(injector.counts)},
        "decisions": counters.get("decisions", 0),
        "plans_superseded": counters.get("plans_superseded", 0),
        "steps_fused_only": counters.get("steps_fused_only", 0),
        "simulation": soak.simulation_lag(),
        "memory": {"daemon_rss_mb_start": baseline[1] if baseline else None, "daemon_rss_mb_end": end[1],
                   "daemon_rss_mb_max": max((m[1] for m in rss), default=None),
                   "daemon_rss_growth_mb": (end[1] - baseline[1]) if baseline and end[1] and baseline[1] else None,
                   "planner_rss_mb_start": baseline[2] if baseline else None, "planner_rss_mb_end": end[2],
                   "samples": [list(m) for m in memory[:: max(1, len(memory) // 200)]]},
        "counters": counters,
    }


def format_report(report: dict) -> str:
    """A few lines: accounting, crashes, faults, memory."""
    published, memory, faults = report["published"], report["memory"], report["faults"]
    mb = (lambda v: "-" if v is None else f"{v:.1f}")
    options = report["options"]
    return "\n".join([
        f"soak: {report['command'] or 'gcs bench soak'}",
        f"machine: {report['machine']}; load average {report['load_average']['start']} at start, "
        f"{report['load_average']['end']} at the end",
        f"{options['vehicles']} vehicles in {options['processes']} processes, {report['simulated_s']:.0f} of "
        f"{options['duration_s']:g} simulated s at {options['rate']:g}x in {report['wall_s']:.0f} s of wall time",
        f"published on the wire: {published['total']:,} samples ({published.get('report', 0):,} reports, "
        f"{published.get('nav', 0):,} nav, {published.get('truth', 0):,} truth; {published['injected']:,} injected)",
        f"received by the daemon: {report['received']:,}; accepted {report['accepted']}; used in decision steps "
        f"{report['used_in_steps']:,} reports; dropped by reason {report['dropped']}",
        f"lost (published - received): {report['lost']}",
        f"crashes: {report['crashes_total']} {report['crashes']}; contained errors {report['errors'] or 'none'}",
        f"faults: {faults['kills']} vehicle processes killed ({faults['restarts']} restarted), "
        f"{faults['silences']} MAVLink silences ({faults['silence_s']:.0f} s), injected {faults['injected']}",
        f"daemon RSS: {mb(memory['daemon_rss_mb_start'])} MB at 10% -> {mb(memory['daemon_rss_mb_end'])} MB at the end "
        f"(growth {mb(memory['daemon_rss_growth_mb'])} MB, max {mb(memory['daemon_rss_mb_max'])}); planner process "
        f"{mb(memory['planner_rss_mb_start'])} -> {mb(memory['planner_rss_mb_end'])} MB",
        f"decisions: {report['decisions']:,} planned ({report['steps_fused_only']:,} steps fused only, a newer one "
        f"planned instead); "
        f"simulation steps started late: {report['simulation']['late_steps']:,} of {report['simulation']['steps']:,} "
        f"(the machine's share of the lateness)",
    ])


def write_json(report: dict, path: Path) -> None:
    """The report as JSON."""
    path.write_text(json.dumps(report, indent=2) + "\n")
