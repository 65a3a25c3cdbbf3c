"""The processes of a ``gcs-bench soak`` run, its observer and its fault schedule (:mod:`benchmarks.soak`).

:class:`SoakFleet` starts the router, the daemon and the vehicle processes on 127.0.0.1, counts every
sample on the wire by kind, and injects the faults. The vehicle processes start their clocks together
(``sim-vehicles run --start-with``) once every one of them is up, however long the machine takes to
start them (:meth:`SoakFleet.wait_until_up`); a process started again after a kill joins the running
clock instead (``--start-at`` in the past).
"""

from __future__ import annotations

import json
import select
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import zenoh

from gcs.adapters.loopback import LOCALHOST
from gcs.adapters.zenoh_session import query
from benchmarks.faults import Injector, every_kind
from benchmarks.soak_report import EPOCH_NS
from benchmarks.urban import with_vehicles
from gcs.scenarios import load_scenario
from protocols.codec import decode
from protocols.keys import status_key
from protocols.messages import DaemonStatus
from sim_vehicles.lockstep import wait_for_vehicles
from sim_vehicles.radio_link import UdpRelay

if TYPE_CHECKING:
    from benchmarks.soak import SoakOptions

__all__ = ["SoakFleet", "scenario_file", "rss_mb", "planner_rss_mb", "STARTUP_TIMEOUT_S"]

NS_PER_S = 1_000_000_000
STARTUP_TIMEOUT_S = 300.0
"""Wall seconds the vehicle processes may take to come up, all of them (a loaded machine starts Python
processes slowly: the wait ends as soon as they are up, this is only how long before giving up)."""


def scenario_file(name: str, count: int, directory: Path) -> Path:
    """A scenario file: the shipped (or given) one with vehicles added up to ``count`` (as ``gcs-bench urban``)."""
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


def rss_mb(pid: int) -> float | None:
    """Resident set of a process (MB), from /proc; None where there is no /proc or the process is gone."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def planner_rss_mb(pid: int) -> float | None:
    """Resident set of the daemon's largest child process (its planner; the others are multiprocessing's helpers)."""
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as children:
            sizes = [rss_mb(int(child)) for child in children.read().split()]
    except OSError:
        return None
    return max((size for size in sizes if size is not None), default=None)


class SoakFleet:
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

    def start_vehicles(self, index: int, start_at: float | None = None) -> None:
        """Start vehicle process ``index``: with ``start_at`` (Unix seconds, past) joining the running clock,
        without it starting its clock with the other processes' (``--start-with`` their vehicles)."""
        only = [arg for v in self.groups[index] for arg in ("--only", v)]
        if start_at is None:
            when = [arg for i, group in enumerate(self.groups) if i != index for v in group
                    for arg in ("--start-with", v)]
        else:
            when = ["--start-at", repr(start_at)]
        self.processes[index] = self._spawn(f"vehicles{index}", [
            sys.executable, "-m", "sim_vehicles.cli", "--log-level", "WARNING", "run",
            "--scenario", str(self.scenario_path), *only, "--seed", str(self.options.seed),
            "--rate", str(self.options.rate), "--duration", str(self.options.duration_s),
            "--epoch-ns", str(EPOCH_NS), *when, "--lockstep", "--mavlink", f"udpout:{LOCALHOST}:{self.relays[index].port}",
            "--zenoh-mode", "client", "--zenoh-connect", self.router_endpoint,
            "--json", str(self.workdir / f"vehicles{index}.json")])
        self.killed.discard(index)

    def wait_until_up(self, session: zenoh.Session, timeout_s: float = STARTUP_TIMEOUT_S) -> float:
        """Wait until every vehicle's liveliness token is up (each process has started its clock at that
        moment, or does within a token's trip); the Unix time then. RuntimeError, naming the vehicles missing,
        when a vehicle process exits first or ``timeout_s`` passes."""
        deadline = time.monotonic() + timeout_s

        def keep_waiting() -> bool:
            return time.monotonic() < deadline and all(p is not None and p.poll() is None for p in self.processes)

        missing = wait_for_vehicles(session, "gcs", [v for group in self.groups for v in group], keep_waiting)
        if missing:
            exited = {i: p.returncode for i, p in enumerate(self.processes) if p is not None and p.poll() is not None}
            why = f"vehicle processes exited ({exited})" if exited else f"not up after {timeout_s:g} s"
            raise RuntimeError(f"{', '.join(sorted(missing))} never came up: {why} (see {self.workdir}/vehicles*.log)")
        return time.time()

    def observed_total(self) -> int:
        """Samples observed on the wire so far, every kind."""
        with self._lock:
            return sum(self.observed.values())

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
