"""The processes of ``gcs-bench federation --processes``: a router, one ``gcs run`` per member, one simulated team each.

Every process runs on 127.0.0.1 and is a Zenoh client of one ``gcs router`` (port 0, read back from
the line it prints; multicast scouting off, as in every session of the project):

* member ``m<i>`` is ``gcs run --prefix m<i> --federation fed --member m<i> --area <strip i>``, its
  MAVLink on a port the system chose (``udpin:127.0.0.1:0``, read back from its ``daemon up`` line);
* its team is ``sim-vehicles run --prefix m<i>``, MAVLink ``udpout`` to that port.

Each member has a scenario file of its own (:func:`member_scenario`): the shipped scenario with its
``[[vehicles]]`` replaced by the member's UAVs, on a ring about its strip's centre (as in
:mod:`benchmarks.federation`; moved inside the city where the ring leaves it), and the sensor's range cut to ``range_m``. Every team flies the same
seed and one clock (``--epoch-ns`` and ``--start-at`` the same past instant: a team that comes up
later joins the clock), so the teams' cars are the same cars at the same stamps.
"""

from __future__ import annotations

import math
import re
import signal
import subprocess
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from benchmarks.federation import RING_M
from benchmarks.urban import with_vehicles
from gcs.adapters.loopback import LOCALHOST
from gcs.adapters.osm.scenario_text import toml_value
from gcs.config import Scenario
from gcs.scenarios import load_scenario

__all__ = ["FEDERATION", "member_scenario", "ProcessLog", "Fleet", "STOP_TIMEOUT_S"]

FEDERATION = "fed"
STOP_TIMEOUT_S = 30.0
"""Wall seconds a process may take to stop after SIGINT before it is killed."""
DAEMON_UP = re.compile(r"daemon up: .*MAVLink (.*)$")
ROUTER_UP = "router listening on "
EDGE_M = 10.0
"""A start on the ring beyond the city's edge (narrow strips: many members) is moved in to this far inside it."""


def _vehicle_block(vehicle) -> str:
    fields = {"id": vehicle.id, "sysid": vehicle.sysid, "altitude_m": vehicle.altitude_m,
              "speed_mps": vehicle.speed_mps, "max_turn_rate_rad_s": vehicle.max_turn_rate_rad_s,
              "start_enu_m": [float(vehicle.start_enu_m[0]), float(vehicle.start_enu_m[1])],
              "start_heading_rad": float(vehicle.start_heading_rad)}
    return "\n[[vehicles]]\n" + "".join(f"{key} = {toml_value(value)}\n" for key, value in fields.items())


def member_scenario(name: str, area: tuple[float, float, float, float], uavs: int, range_m: float,
                    path: Path) -> Scenario:
    """Write the member's scenario file (module docstring) to ``path``; the scenario it loads as."""
    from importlib import resources

    import msgspec

    text = (resources.files("gcs.scenarios") / f"{name}.toml").read_text()
    kept, section = [], ""
    for line in text.splitlines():
        if line.startswith("["):
            section = line.split("#", 1)[0].strip()
        if section == "[[vehicles]]" or section.startswith("[vehicles."):
            continue
        if section == "[sensor]" and line.split("=", 1)[0].strip() == "max_range_m":
            line = f"max_range_m = {toml_value(float(range_m))}"
        kept.append(line)
    x0, y0, x1, y1 = area
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    base = load_scenario(name)
    width, height = base.city.size_m
    vehicles = []
    for i, vehicle in enumerate(with_vehicles(base, uavs).vehicles):
        angle = 2.0 * math.pi * i / uavs
        heading = math.remainder(angle + math.pi / 2, 2 * math.pi)
        x = min(max(cx + RING_M * math.cos(angle), EDGE_M), width - EDGE_M)
        y = min(max(cy + RING_M * math.sin(angle), EDGE_M), height - EDGE_M)
        vehicles.append(msgspec.structs.replace(vehicle, start_enu_m=(x, y), start_heading_rad=heading))
    path.write_text("\n".join(kept) + "\n" + "".join(_vehicle_block(v) for v in vehicles))
    scenario = load_scenario(path)
    if len(scenario.vehicles) != uavs or scenario.sensor.max_range_m != range_m:
        raise RuntimeError(f"{path}: the member's scenario did not come out as written")
    return scenario


class ProcessLog:
    """A process's stderr (or stdout) copied to a file on a thread; waits for the first line matching a pattern."""

    def __init__(self, stream: IO[str], path: Path, pattern: re.Pattern | str) -> None:
        self.pattern = re.compile(pattern) if isinstance(pattern, str) else pattern
        self.match: re.Match | None = None
        self.path = path
        self._found = threading.Event()
        self._thread = threading.Thread(target=self._copy, args=(stream,), daemon=True)
        self._thread.start()

    def _copy(self, stream: IO[str]) -> None:
        with open(self.path, "a") as out:
            for line in stream:
                out.write(line)
                out.flush()
                if self.match is None and (match := self.pattern.search(line)):
                    self.match = match
                    self._found.set()
        self._found.set()  # the stream ended: whoever waits learns there is no match

    def wait(self, timeout_s: float) -> re.Match:
        """The matching line; RuntimeError when the stream ends or ``timeout_s`` passes first."""
        if not self._found.wait(timeout_s) or self.match is None:
            raise RuntimeError(f"no line matching {self.pattern.pattern!r} within {timeout_s:g} s (see {self.path})")
        return self.match

    def close(self) -> None:
        self._thread.join(timeout=STOP_TIMEOUT_S)


@dataclass
class Fleet:
    """The router, the member daemons and their teams: started in turn, stopped together (:meth:`stop`)."""

    workdir: Path
    seed: int
    fusion: str
    router_endpoint: str = ""
    processes: dict[str, subprocess.Popen] = field(default_factory=dict)
    logs: list[ProcessLog] = field(default_factory=list)

    def _spawn(self, name: str, argv: list[str], pattern: str | re.Pattern, from_stdout: bool = False) -> ProcessLog:
        process = subprocess.Popen(argv, stdin=subprocess.DEVNULL, text=True,
                                   stdout=subprocess.PIPE if from_stdout else subprocess.DEVNULL,
                                   stderr=subprocess.STDOUT if from_stdout else subprocess.PIPE)
        self.processes[name] = process
        stream = process.stdout if from_stdout else process.stderr
        assert stream is not None  # a pipe, as asked
        log = ProcessLog(stream, self.workdir / f"{name}.log", pattern)
        self.logs.append(log)
        return log

    def start_router(self, timeout_s: float) -> str:
        """Start the router on a port the system chooses; its endpoint."""
        log = self._spawn("router", [sys.executable, "-m", "gcs.cli", "router", "--zenoh-listen",
                                     f"tcp/{LOCALHOST}:0"], ROUTER_UP + r"(tcp/\S+?)(,|\s|$)", from_stdout=True)
        self.router_endpoint = log.wait(timeout_s).group(1)
        return self.router_endpoint

    def start_member(self, member: str, scenario: Path, area: tuple[float, float, float, float]) -> ProcessLog:
        """Start member ``member``'s daemon; its log, which says (:meth:`mavlink_port`) where it listens."""
        return self._spawn(member, [
            sys.executable, "-m", "gcs.cli", "run", "--scenario", str(scenario), "--prefix", member,
            "--seed", str(self.seed), "--zenoh-mode", "client", "--zenoh-connect", self.router_endpoint,
            "--mavlink", f"udpin:{LOCALHOST}:0", "--http", "none", "--federation", FEDERATION, "--member", member,
            f"--area={','.join(repr(float(v)) for v in area)}", "--fusion", self.fusion], DAEMON_UP)

    @staticmethod
    def mavlink_port(log: ProcessLog, timeout_s: float) -> int:
        """The MAVLink port a member's daemon bound, from its ``daemon up`` line."""
        ports = {int(port) for port in re.findall(r"udpin:[\d.]+:(\d+)", log.wait(timeout_s).group(1))}
        if len(ports) != 1:
            raise RuntimeError(f"the daemon's MAVLink ports are {sorted(ports)}, not one (see {log.path})")
        return ports.pop()

    def start_team(self, member: str, scenario: Path, port: int, epoch_s: int) -> None:
        """Start member ``member``'s simulated team on the clock that started at Unix second ``epoch_s``."""
        self._spawn(f"{member}-team", [
            sys.executable, "-m", "sim_vehicles.cli", "--log-level", "WARNING", "run", "--scenario", str(scenario),
            "--prefix", member, "--seed", str(self.seed), "--rate", "1", "--epoch-ns", str(epoch_s * 1_000_000_000),
            "--start-at", str(epoch_s), "--mavlink", f"udpout:{LOCALHOST}:{port}", "--zenoh-mode", "client",
            "--zenoh-connect", self.router_endpoint], "$^")

    def exited(self) -> dict[str, int]:
        """The processes that have exited, with their status."""
        return {name: code for name, process in self.processes.items() if (code := process.poll()) is not None}

    def stop(self) -> dict[str, int]:
        """SIGINT every process still running (the teams first, the router last), kill those that do not stop
        within :data:`STOP_TIMEOUT_S`; every process's exit status."""
        teams_first = sorted((name for name in self.processes if name != "router"), key=lambda name: not name.endswith("-team"))
        for name in teams_first:
            self._interrupt(name)
        codes = {name: self._wait(name) for name in teams_first}
        if "router" in self.processes:
            self._interrupt("router")
            codes["router"] = self._wait("router")
        for log in self.logs:
            log.close()
        return codes

    def _interrupt(self, name: str) -> None:
        if self.processes[name].poll() is None:
            self.processes[name].send_signal(signal.SIGINT)

    def _wait(self, name: str) -> int:
        process = self.processes[name]
        try:
            return process.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            return process.wait()
