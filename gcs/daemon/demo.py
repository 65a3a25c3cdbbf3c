"""``gcs demo``: the daemon and the simulated vehicles on loopback, with a live line and a summary.

The simulated vehicles run as a separate process (``sim-vehicles run``), the
daemon in this one; they meet on loopback ports the system chooses: the
daemon's Zenoh peer listens on ``tcp/127.0.0.1:0`` and the vehicles connect to
the port it got (no router), and the vehicles send MAVLink to the port its
``udpin:127.0.0.1:0`` got. The
summary scores the daemon's track against the simulator's published truth,
with the same quantities as ``gcs bench urban``: decision steps, steps seen by
any UAV and by each, fused position RMSE, decision time.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from gcs.app import Daemon
from gcs.cli_errors import one_line, positive, set_command
from gcs.daemon.records import PlanRecord, StepRecord, step_error_m
from gcs.daemon.cli import add_daemon_arguments, build_daemon

DEFAULT_RATE = 10.0
"""Simulation speed-up of ``gcs demo`` (and of ``make demo`` and ``gcs bench demo``).

At R times real time a decision step of 1 s lasts 1/R s of wall time, and the
planner's deadline is a share of it (``gcs.daemon.planning``): at 10x its search is
cut at 30 ms, at 5x it runs to its end. Over seeds 0-9 the demo at 5x and at 10x is
as close to the in-process loop either way (docs/benchmarks.md, the ``gcs demo``
section), so the demo keeps the shorter run. Real vehicles fly at 1x, where the
planner has ten times longer."""

__all__ = ["add_demo", "summarise", "check_demo", "simulator_command", "run_together"]

log = logging.getLogger(__name__)


def add_demo(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs demo``."""
    parser = sub.add_parser(
        "demo", help="daemon + simulated vehicles on loopback, live progress and a summary",
        description="Run the ground station against simulated vehicles (a separate process) on 127.0.0.1, "
                    "show one line of progress, and print observations and RMSE against the truth.")
    add_daemon_arguments(parser)
    parser.add_argument("--duration", type=float, default=None, metavar="S",
                        help="simulated seconds (default: the scenario's, 300 s for wang2012_urban)")
    parser.add_argument("--rate", type=float, default=DEFAULT_RATE,
                        help=f"simulation speed-up (default {DEFAULT_RATE:g})")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="write the summary: steps, seen_any, seen_per_uav, rmse_m, ...")
    set_command(parser, _cmd_demo, check_demo)


def summarise(records: list[StepRecord], plans: list[PlanRecord], vehicles: list[str],
              targets: Sequence[str] = ()) -> dict:
    """The demo's summary of the daemon's decision steps and of its plans (``decision_ms``: the planner's solve);
    with many targets, the steps each of ``targets`` had a track on it."""
    errors = np.array([r.error_m for r in records if r.error_m is not None])
    decisions = np.array([p.solve_s for p in plans]) * 1e3
    nav_std = np.array([s for r in records for s in r.nav_std_m.values()])
    return {
        "steps": len(records),
        "seen_any": sum(any(r.seen.values()) for r in records),
        "seen_per_uav": {v: sum(r.seen.get(v, False) for r in records) for v in vehicles},
        "rmse_m": float(np.sqrt(np.mean(errors**2))) if errors.size else None,
        "scored_steps": int(errors.size),
        "decision_ms_median": float(np.median(decisions)) if decisions.size else None,
        "decision_ms_p99": float(np.percentile(decisions, 99)) if decisions.size else None,
        "nav_std_m_median": float(np.median(nav_std)) if nav_std.size else None,
        "nav_std_m_max": float(nav_std.max()) if nav_std.size else None,
        "nav_vehicle_steps_without_fix": sum(not fix for r in records for fix in r.gps_fix.values()),
        **_many_targets(records, targets),
    }


def _many_targets(records: list[StepRecord], targets: Sequence[str]) -> dict:
    """With ``[multitarget]``: mean GOSPA of the scored steps and, per target, the steps a track was on it."""
    scored = [r for r in records if r.gospa_m is not None]
    if not any(r.tracks_xy is not None for r in records):
        return {}
    per_target = {name: 0 for name in targets}
    for record in scored:
        for name in record.tracked:
            per_target[name] = per_target.get(name, 0) + 1
    return {"gospa_m_mean": float(np.mean([r.gospa_m for r in scored])) if scored else None,
            "gospa_steps": len(scored), "tracks_last_step": len(records[-1].tracks_xy or ()) if records else 0,
            "tracked_steps_per_target": dict(sorted(per_target.items()))}


class _Progress:
    """One line, rewritten in place on a terminal; a line every 30 steps otherwise."""

    def __init__(self, stream, duration_s: float) -> None:
        self.stream, self.duration_s = stream, duration_s
        self.tty = stream.isatty()
        self.seen = self.steps = 0
        self.squares, self.scored = 0.0, 0
        self.solve_s: float | None = None

    def planned(self, record: PlanRecord) -> None:
        self.solve_s = record.solve_s

    def __call__(self, record: StepRecord) -> None:
        self.steps += 1
        self.seen += any(record.seen.values())
        error = step_error_m(record)
        if error is not None:
            self.squares += error**2
            self.scored += 1
        name = "RMSE" if record.tracks_xy is None else "GOSPA RMS"  # many targets: GOSPA against every truth
        rmse = f"{math.sqrt(self.squares / self.scored):6.1f} m" if self.scored else "     - "
        decision = f"{self.solve_s * 1e3:5.0f} ms" if self.solve_s is not None else "    - "
        line = (f"step {self.steps:4d}/{self.duration_s:.0f}  seen by any {self.seen:4d}  {name} {rmse}  "
                f"decision {decision}  UAVs {len(record.vehicles)}")
        if self.tty:
            self.stream.write("\r" + line)
            self.stream.flush()
        elif self.steps % 30 == 0:
            self.stream.write(line + "\n")

    def end(self) -> None:
        if self.tty:
            self.stream.write("\n")


def check_demo(args: argparse.Namespace) -> Daemon:
    """``gcs demo``'s input, checked: the daemon it runs (not opened), on loopback ports the system chooses."""
    positive(args.duration, "--duration")
    positive(args.rate, "--rate")
    args.mavlink, args.vehicle = "udpin:127.0.0.1:0", []
    args.signing_passphrase = args.signing_key_file = None
    args.zenoh_mode, args.zenoh_listen, args.zenoh_connect = "peer", ["tcp/127.0.0.1:0"], []
    args.zenoh_default_listen = args.zenoh_default_connect = ()
    args.prefix = "gcs"
    return build_daemon(args)


def _cmd_demo(args: argparse.Namespace) -> int:
    daemon = check_demo(args)
    duration = args.duration if args.duration is not None else daemon.scenario.time.duration_s
    progress = _Progress(sys.stderr, duration)
    daemon.on_step, daemon.on_plan = progress, progress.planned
    try:
        daemon.open()  # before the vehicles start, and so that its ports and the live map's address are known
    except (RuntimeError, OSError, ValueError) as error:
        print(f"gcs demo: error: {one_line(error)}", file=sys.stderr)
        daemon.close()
        return 1
    (endpoint,) = daemon.zenoh_listening
    (mavlink,) = set(daemon.mavlink_bound.values())  # one port, shared by the vehicles
    command = simulator_command(daemon, args.scenario, args.rate, duration, args.seed)
    log_file = Path(tempfile.gettempdir()) / f"gcs-demo-sim-vehicles-{mavlink.rsplit(':', 1)[1]}.log"
    print(f"demo: {daemon.scenario.name}, {len(daemon.scenario.vehicles)} UAVs, {duration:g} s at {args.rate:g}x; "
          f"zenoh {endpoint}, MAVLink {mavlink}; simulator log {log_file}", flush=True)
    live = daemon.live
    print(f"live map: {(live.url if live is not None else None) or 'off'}", flush=True)
    if live is not None and live.foxglove is not None:
        print(f"foxglove: {live.foxglove.url or 'no server'}" + (f", MCAP {args.foxglove_mcap}" if args.foxglove_mcap
                                                                else ""), flush=True)
    stopped = run_together(daemon, command, log_file)
    progress.end()
    summary = summarise(daemon.records, daemon.plans, daemon.roster, [t.id for t in daemon.scenario.all_targets])
    counters = daemon.status(time.monotonic()).counters
    summary.update({"scenario": daemon.scenario.name, "planner": daemon.planner_name, "rate": args.rate,
                    "duration_s": duration, "navigation": "reported" if daemon.navigator is None else "skf",
                    "command_age_ms_median": daemon.engine.command_ages.median_ms(),
                    "command_age_ms_p99": daemon.engine.command_ages.p99_ms(),
                    "steps_released_by_timeout": counters.get("steps_released_by_timeout", 0),
                    "rejected": {k: v for k, v in counters.items() if k.startswith("rejected.")}})
    _print_summary(summary)
    if args.json is not None:
        args.json.write_text(json.dumps(summary, indent=2))
    return 130 if stopped else 0


def simulator_command(daemon: Daemon, scenario: str, rate: float, duration_s: float, seed: int,
                      extra: tuple[str, ...] = ()) -> list[str]:
    """The ``sim-vehicles run`` command line that flies ``scenario`` against the opened ``daemon``: its MAVLink
    port (one, shared by the vehicles) and its Zenoh endpoint, at ``rate`` for ``duration_s``, ``extra``
    options appended."""
    (endpoint,) = daemon.zenoh_listening
    (mavlink,) = set(daemon.mavlink_bound.values())
    return [sys.executable, "-m", "sim_vehicles.cli", "--log-level", "WARNING", "run", "--scenario", scenario,
            "--rate", str(rate), "--duration", str(duration_s), "--seed", str(seed),
            "--mavlink", f"udpout:127.0.0.1:{mavlink.rsplit(':', 1)[1]}", "--zenoh-connect", endpoint, *extra]


def run_together(daemon: Daemon, command: list[str], log_file: Path) -> bool:
    """Run the simulator process and the daemon until the simulator ends; True if interrupted."""
    interrupted = []

    def on_signal(signum, frame) -> None:
        interrupted.append(signum)
        daemon.stop()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    with open(log_file, "w") as log_stream:
        simulator = subprocess.Popen(command, stdout=log_stream, stderr=subprocess.STDOUT)
        finished: list[float] = []

        def done() -> bool:
            if simulator.poll() is not None and not finished:
                finished.append(time.monotonic())
            return bool(finished) and time.monotonic() - finished[0] > 1.0  # let the last step through

        try:
            daemon.run(until=done)
        finally:
            if simulator.poll() is None:
                simulator.send_signal(signal.SIGINT)
                try:
                    simulator.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    simulator.kill()
                    simulator.wait()
            for signum, handler in previous.items():
                signal.signal(signum, handler)
    if simulator.returncode not in (0, -signal.SIGINT) and not interrupted:
        log.error("the simulated vehicles exited with %s; see %s", simulator.returncode, log_file)
    return bool(interrupted)


def _print_summary(summary: dict) -> None:
    per_uav = ", ".join(f"{v} {n}" for v, n in summary["seen_per_uav"].items())
    rmse = f"{summary['rmse_m']:.1f} m over {summary['scored_steps']} steps" if summary["rmse_m"] is not None else "-"
    median, p99 = (_ms(summary[key]) for key in ("decision_ms_median", "decision_ms_p99"))
    print(f"steps {summary['steps']}; seen by at least one UAV {summary['seen_any']}; per UAV {per_uav}")
    fused = "" if "gospa_m_mean" in summary else f"fused position RMSE {rmse}; "  # many targets: GOSPA below
    print(f"{fused}decision time median {median}, p99 {p99}")
    if summary.get("command_age_ms_median") is not None:
        print(f"command age (vehicle time flown less the decision step's stamp) median "
              f"{_ms(summary['command_age_ms_median'])}, p99 {_ms(summary['command_age_ms_p99'])}")
    if summary.get("nav_std_m_median") is not None:
        print(f"navigation {summary['navigation']}: vehicle position 1-sigma median {summary['nav_std_m_median']:.1f} m, "
              f"max {summary['nav_std_m_max']:.1f} m; {summary['nav_vehicle_steps_without_fix']} vehicle-steps "
              "without GPS")
    if "gospa_m_mean" in summary:
        per_target = ", ".join(f"{t} {n}" for t, n in summary["tracked_steps_per_target"].items()) or "none"
        gospa = "-" if summary["gospa_m_mean"] is None else f"{summary['gospa_m_mean']:.1f} m"
        print(f"tracks: GOSPA mean {gospa} over {summary['gospa_steps']} steps; {summary['tracks_last_step']} "
              f"confirmed at the end; steps with a track on each target: {per_target}")
    if summary["rejected"]:
        print("rejected: " + ", ".join(f"{k} {v}" for k, v in sorted(summary["rejected"].items())))
    print("compare: gcs bench urban (the same loop in one process, without the network and the airframe lag)")


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.0f} ms"
