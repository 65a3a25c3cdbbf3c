"""``gcs bench soak``: the whole ground station for a long simulated run with random faults, accounted for.

Processes on 127.0.0.1, as in the field: a ``gcs router``; the daemon
(``gcs run``, a Zenoh client of the router, MAVLink per vehicle group); the
vehicles (``sim-vehicles run --lockstep``, a few vehicles per process, clients
of the router, all on one simulation clock, which a process that falls behind
holds back for all: :mod:`sim_vehicles.lockstep`) whose MAVLink goes through a
:class:`~gcs.bench.faults.UdpRelay` each; and this process, an **observer**
that subscribes to everything the daemon consumes (through the same router,
so it sees exactly what is on the wire) and injects faults at random
(exponential gaps, mean ``fault_every_s`` of wall time):

* ``kill``: SIGKILL a vehicle process (one whose vehicles are on the wire, and
  never the last such: that kill is a burst of bad samples instead); it is
  started again 1-4 s later and
  joins the clock (``--start-at`` in the past: its target is moved to the
  running vehicles' time before its vehicles report);
* ``silence``: mute a process's MAVLink relay for 2-8 s;
* ``inject``: a burst of bad samples (:data:`~gcs.bench.faults.INJECTIONS`).

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

import json
import select
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import zenoh

from gcs.adapters.loopback import LOCALHOST
from gcs.adapters.zenoh_session import ZenohSettings, open_session, query
from gcs.bench.daemon import _load_average, machine_note
from gcs.bench.faults import Injector, UdpRelay, every_kind
from gcs.bench.soak_report import EPOCH_NS, POST_INGEST, build_report, format_report, received, write_json
from gcs.bench.urban import with_vehicles
from gcs.cli_errors import INTERRUPTED_STATUS
from gcs.scenarios import load_scenario
from protocols.codec import decode
from protocols.keys import navs_selector, reports_selector, scenarios_selector, status_key, truth_selector
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
        self.router_endpoint = ""  # the router's, once it has said where it listens
        self.relays: list[UdpRelay] = []
        self.observed: Counter = Counter()
        self.heard_s: dict[str, float] = {}
        """Each vehicle's latest nav or report on the wire (monotonic wall seconds)."""
        self.crashes: Counter = Counter()
        self.faults: Counter = Counter()
        self.silence_s = 0.0
        self.processes: list[subprocess.Popen | None] = [None] * len(self.groups)
        self.killed: set[int] = set()
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
                                        f"tcp/{LOCALHOST}:0"], stdout=subprocess.PIPE)
        ready, _, _ = select.select([router.stdout], [], [], 60.0)
        line = router.stdout.readline() if ready else ""
        if not line.startswith("router listening on tcp/"):
            raise RuntimeError(f"the router did not start (see {self.workdir / 'router.log'})")
        self.router_endpoint = line.removeprefix("router listening on ").split(",")[0].strip()
        return router

    def start_daemon(self) -> subprocess.Popen:
        vehicles = [f"{v}=udpout:{LOCALHOST}:{relay.ground_port}" for group, relay in zip(self.groups, self.relays)
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
            "--lockstep", "--mavlink", f"udpout:{LOCALHOST}:{self.relays[index].port}",
            "--zenoh-mode", "client", "--zenoh-connect", self.router_endpoint,
            "--json", str(self.workdir / f"vehicles{index}.json")])
        self.killed.discard(index)

    def simulation_lag(self) -> dict:
        """From the vehicle processes that ran to the end: physics steps started late (behind the wall
        schedule: the machine did not give the process the CPU it needed, or lockstep held it for another),
        steps held for the other vehicles and the wall seconds they were held, out of all steps."""
        totals = Counter()
        for index in range(len(self.groups)):
            path = self.workdir / f"vehicles{index}.json"
            if path.exists():
                summary = json.loads(path.read_text())
                totals.update({key: summary[key] for key in ("late_steps", "steps", "held_steps", "held_s")})
        return {key: totals[key] for key in ("late_steps", "steps", "held_steps", "held_s")}

    # ------------------------------------------------------------- observer

    def observe(self, injector: Injector) -> Callable[[zenoh.Sample], None]:
        def on_sample(sample: zenoh.Sample) -> None:
            key = str(sample.key_expr)
            kind = key.rsplit("/", 1)[-1] if "/vehicle/" in key else "truth"
            with self._lock:
                self.observed[kind] += 1
                if kind in ("report", "nav"):
                    self.heard_s[key.split("/vehicle/", 1)[1].split("/", 1)[0]] = time.monotonic()
            injector.observe(key, sample.payload.to_bytes(), str(sample.encoding))
        return on_sample

    def _flying(self, now: float) -> list[int]:
        """The vehicle processes whose vehicles are on the wire (heard within the last second): a kill leaves
        one of them flying, for the restarted processes to join (with every vehicle down, the daemon hears
        nobody while a restarted process starts up, and its first stamps come a start-up's worth of
        simulated time after the daemon's newest)."""
        with self._lock:
            return [i for i, group in enumerate(self.groups) if i not in self.killed
                    and any(now - self.heard_s.get(v, -1e9) <= 1.0 for v in group)]

    def clock_start(self, injector: Injector, start_at: float) -> float:
        """The ``--start-at`` of a restarted vehicle process: where the vehicles' data is now (the newest
        report on the wire), not where the wall clock says it should be, since a run the machine cannot keep
        at its rate is behind that. With other vehicles running, lockstep joins it to them anyway; this is
        for the process that restarts while every other is down too (no one to join)."""
        newest = injector.newest_ns
        if newest is None or newest <= EPOCH_NS:
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
        if kind == "kill" and len(self._flying(now)) >= 2:
            index = int(self.rng.choice(self._flying(now)))
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
        for selector in (reports_selector(), navs_selector(), truth_selector(), scenarios_selector()):
            session.declare_subscriber(selector, on_sample)
        soak.relays = [UdpRelay() for _ in soak.groups]
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
                    soak.start_vehicles(index, soak.clock_start(injector, start_at))
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
        if code not in (0, INTERRUPTED_STATUS):  # 130: ended by the SIGINT sent above, as after Ctrl-C
            soak.crashes[name] += 1
    return build_report(options, soak, status, dict(injector.counts), memory, baseline, end, exit_codes, command,
                        note, load_start, time.monotonic() - started, workdir)


def _drain(soak: _Soak, session: zenoh.Session, say: Callable[[str], None], timeout_s: float = 60.0) -> DaemonStatus:
    """The daemon's status once it has taken in every sample observed (or ``timeout_s`` passed)."""
    deadline = time.monotonic() + timeout_s
    while True:
        status = soak.status(session)
        with soak._lock:
            observed = sum(soak.observed.values())
        if status is not None and (received(status.counters) >= observed or time.monotonic() > deadline):
            return status
        if time.monotonic() > deadline:
            raise RuntimeError("the daemon's status stopped answering")
        say(f"draining: the daemon took in {received(status.counters) if status else '?'} of {observed}")
        time.sleep(0.5)
