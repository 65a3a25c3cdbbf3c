"""The federation's processes for a system test: a ``gcs router``, one ``gcs run`` member per team and one
``sim-vehicles run`` per team, all on loopback; and an observer, a Zenoh client of the router of the test's own.

Every process is a console script started with :class:`subprocess.Popen`; its standard error goes to a log file
beside the test's other files (printed when the test fails). :meth:`Fleet.close` stops every one still running
(SIGINT, then SIGKILL), so that a failing test leaves nothing behind.
"""

from __future__ import annotations

import bisect
import subprocess
import threading
from dataclasses import dataclass, field
from pathlib import Path

import zenoh

from gcs.adapters.zenoh_session import ZenohSettings, open_session, query
from protocols.codec import decode
from protocols.federation import FederatedTrack, MemberTracks
from protocols.keys import member_tracks_selector, status_key, truth_selector
from protocols.messages import TargetTruth
from protocols.status import DaemonStatus
from tests.e2e.processes import script, stop
from tests.integration.sim_harness import wait_until
from tests.loopback import ANY_PORT_ENDPOINT

__all__ = ["Team", "Fleet", "Observer", "track_on", "distance", "NS_PER_S"]

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class Team:
    """One member of the federation: its prefix and member id, its area (``--area``) and its vehicles."""

    name: str
    area: str
    vehicles: tuple[str, ...]


@dataclass
class Fleet:
    """The processes of one federation, started and stopped by the test (module docstring)."""

    scenario: str
    federation: str
    teams: dict[str, Team]
    seed: int
    rate: float
    logs: Path
    endpoint: str = ""
    processes: dict[str, subprocess.Popen] = field(default_factory=dict)
    _started: int = 0

    def _popen(self, name: str, command: list[str], **kwargs) -> subprocess.Popen:
        self._started += 1
        log = self.logs / f"{self._started:02d}-{name}.log"
        with open(log, "w") as stderr:
            process = subprocess.Popen(command, stderr=stderr, **kwargs)
        process.log = log
        self.processes[f"{name}#{self._started}"] = process
        return process

    def start_router(self) -> subprocess.Popen:
        """``gcs router`` on a port the system chose the first time, on that same port when started again."""
        router = self._popen("router", [script("gcs"), "router", "--zenoh-listen", self.endpoint or ANY_PORT_ENDPOINT],
                             stdout=subprocess.PIPE, text=True)
        line = router.stdout.readline()
        assert line.startswith("router listening on "), (line, router.log.read_text())
        self.endpoint = line.removeprefix("router listening on ").split(",")[0].strip()
        return router

    def start_daemon(self, team: str) -> subprocess.Popen:
        """The team's ``gcs run``, a member of the federation and a client of the router, without MAVLink (its
        vehicles fly their own way) and without a live map; returned once it says it is up."""
        daemon = self._popen(f"gcs-run-{team}", [
            script("gcs"), "run", "--scenario", self.scenario, "--prefix", team, "--federation", self.federation,
            "--member", team, "--area", self.teams[team].area, "--zenoh-mode", "client", "--zenoh-connect",
            self.endpoint, "--mavlink", "none", "--http", "none", "--plan-in", "thread"], stdout=subprocess.DEVNULL)
        wait_until(lambda: daemon.poll() is not None or "daemon up" in daemon.log.read_text(), 60,
                   f"{team}'s daemon to come up")
        assert daemon.poll() is None, daemon.log.read_text()
        return daemon

    def start_vehicles(self, team: str, start_at: float) -> subprocess.Popen:
        """The team's own vehicles under its prefix; every team's simulator has the same seed and clock, so the
        same cars."""
        only = [arg for vehicle in self.teams[team].vehicles for arg in ("--only", vehicle)]
        return self._popen(f"sim-vehicles-{team}", [
            script("sim-vehicles"), "run", "--scenario", self.scenario, "--prefix", team, *only,
            "--seed", str(self.seed), "--rate", str(self.rate), "--epoch-ns", "0", "--start-at", f"{start_at:.3f}",
            "--mavlink", "none", "--zenoh-mode", "client", "--zenoh-connect", self.endpoint], stdout=subprocess.DEVNULL)

    def close(self) -> None:
        for process in self.processes.values():
            stop(process)

    def report(self) -> str:
        """Every process's exit status and the end of its log, for a failing test's output."""
        return "\n".join(f"--- {name} (exit {p.poll()}):\n{p.log.read_text()[-3000:]}"
                         for name, p in self.processes.items())


class Observer:
    """A client of the router that keeps every member's :class:`MemberTracks` and the cars' truth as they come,
    and asks the daemons for their status."""

    def __init__(self, endpoint: str, federation: str, truth_prefix: str) -> None:
        self.messages: dict[str, list[MemberTracks]] = {}
        self.truth: dict[str, list[tuple[int, float, float]]] = {}
        self.rejected: list[str] = []
        self._lock = threading.Lock()
        self._session = open_session(ZenohSettings(mode="client", connect=(endpoint,)))
        self._session.declare_subscriber(member_tracks_selector(federation), self._on_member)
        self._session.declare_subscriber(truth_selector(truth_prefix), self._on_truth)

    def close(self) -> None:
        self._session.close()

    def _on_member(self, sample: zenoh.Sample) -> None:
        try:
            message = decode(sample.payload.to_bytes(), str(sample.encoding), MemberTracks)
        except Exception as error:  # noqa: BLE001 - kept and asserted empty by the test
            self.rejected.append(f"{sample.key_expr}: {error}")
            return
        with self._lock:
            self.messages.setdefault(message.member_id, []).append(message)

    def _on_truth(self, sample: zenoh.Sample) -> None:
        truth = decode(sample.payload.to_bytes(), str(sample.encoding), TargetTruth)
        with self._lock:
            rows = self.truth.setdefault(truth.target_id, [])
            if not rows or truth.stamp_ns > rows[-1][0]:
                rows.append((truth.stamp_ns, *truth.position_enu_m))

    def of(self, member: str, after_ns: int = -1) -> list[MemberTracks]:
        """The member's messages so far, those stamped after ``after_ns`` only."""
        with self._lock:
            return [m for m in self.messages.get(member, ()) if m.stamp_ns > after_ns]

    def latest(self, member: str) -> MemberTracks | None:
        with self._lock:
            rows = self.messages.get(member)
            return rows[-1] if rows else None

    def car_at(self, car: str, stamp_ns: int) -> tuple[float, float] | None:
        """The car's true position at the truth sample nearest ``stamp_ns`` (None: none within a second)."""
        with self._lock:
            rows = list(self.truth.get(car, ()))
        index = bisect.bisect_left(rows, (stamp_ns,))
        near = [rows[i] for i in (index - 1, index) if 0 <= i < len(rows)]
        if not near:
            return None
        best = min(near, key=lambda row: abs(row[0] - stamp_ns))
        return (best[1], best[2]) if abs(best[0] - stamp_ns) <= NS_PER_S else None

    def cars(self) -> list[str]:
        with self._lock:
            return sorted(self.truth)

    def status(self, prefix: str, timeout_s: float = 5.0) -> DaemonStatus:
        """The daemon's status, asked on ``<prefix>/daemon/status``."""
        for sample in query(self._session, status_key(prefix), timeout_s):
            return decode(sample.payload.to_bytes(), str(sample.encoding), DaemonStatus)
        raise AssertionError(f"no status from {prefix}'s daemon within {timeout_s} s")


def distance(track: FederatedTrack, position: tuple[float, float]) -> float:
    return ((track.state[0] - position[0]) ** 2 + (track.state[1] - position[1]) ** 2) ** 0.5


def track_on(observer: Observer, message: MemberTracks, car: str, gate_m: float) -> FederatedTrack | None:
    """The member's track on ``car`` in ``message``: its track nearest the car's truth, within ``gate_m``, and
    nearer that car than any other car (None: it holds none)."""
    here = observer.car_at(car, message.stamp_ns)
    if here is None or not message.tracks:
        return None
    track = min(message.tracks, key=lambda t: distance(t, here))
    if distance(track, here) > gate_m:
        return None
    others = [observer.car_at(other, message.stamp_ns) for other in observer.cars() if other != car]
    if any(p is not None and distance(track, p) < distance(track, here) for p in others):
        return None
    return track


