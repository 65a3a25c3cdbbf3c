"""``gcs demo``: the daemon and the simulated vehicles on loopback, with a live line and a summary.

The simulated vehicles run as a separate process (``sim-vehicles run``), the
daemon in this one; they meet on loopback ports the system chooses: the
daemon's Zenoh peer listens on ``tcp/127.0.0.1:0`` and the vehicles connect to
the port it got (no router), and the vehicles send MAVLink to the port its
``udpin:127.0.0.1:0`` got. The
summary (:mod:`gcs.daemon.demo_summary`) scores the daemon's track against the
simulator's published truth: decision steps, steps seen by any UAV and by each,
fused position RMSE (GOSPA mean with many targets), decision time, and the
steering commands' age against the decision period. Ctrl-C stops both processes;
the summary of the steps flown is printed, saying it was interrupted.
"""

from __future__ import annotations

import argparse
import json
import logging
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from gcs.daemon.app import Daemon
from gcs.cli_errors import one_line, positive, set_command, stop_on_signals, stopped_by
from gcs.daemon.cli import add_daemon_arguments, build_daemon
from gcs.daemon.demo_summary import Progress, print_summary, summarise

DEFAULT_RATE = 10.0
"""Simulation speed-up of ``gcs demo`` (and of ``make demo`` and ``gcs-bench demo``).

At R times real time a decision step of 1 s lasts 1/R s of wall time, and the
planner's deadline is a share of it (``gcs.daemon.plan_runners``): at 10x its search is
cut at 30 ms, at 5x it runs to its end. Over seeds 0-9 the demo at 5x and at 10x is
as close to the in-process loop either way (docs/benchmarks.md, the ``gcs demo``
section), so the demo keeps the shorter run. Real vehicles fly at 1x, where the
planner has ten times longer."""

STOPPED_WELL = (0, 128 + signal.SIGINT, 128 + signal.SIGTERM, -signal.SIGINT, -signal.SIGTERM)
"""The simulator's exit statuses that are no failure: done, or stopped by Ctrl-C or SIGTERM."""

__all__ = ["add_demo", "summarise", "check_demo", "simulator_command", "run_together", "STOPPED_WELL"]

log = logging.getLogger(__name__)


def add_demo(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs demo``."""
    parser = sub.add_parser(
        "demo", help="daemon + simulated vehicles on loopback, live progress and a summary",
        description="Run the ground station against simulated vehicles (a separate process) on 127.0.0.1, "
                    "show one line of progress, and print observations and RMSE against the truth. Ctrl-C stops it "
                    "with a summary of the steps flown.")
    add_daemon_arguments(parser)
    parser.add_argument("--duration", type=float, default=None, metavar="S",
                        help="simulated seconds (default: the scenario's, 300 s for wang2012_urban)")
    parser.add_argument("--rate", type=float, default=DEFAULT_RATE,
                        help=f"simulation speed-up (default {DEFAULT_RATE:g})")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="write the summary: steps, seen_any, seen_per_uav, rmse_m, interrupted, ...")
    set_command(parser, _cmd_demo, check_demo)


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
    progress = Progress(sys.stderr, duration)
    daemon.on_step, daemon.on_plan = progress, progress.planned
    try:
        daemon.open()  # before the vehicles start, and so that its ports and the live map's address are known
    except (RuntimeError, OSError, ValueError) as error:
        print(f"gcs demo: error: {one_line(error)}", file=sys.stderr)
        daemon.close()
        return 1
    try:
        _print_header(daemon, args, duration)
        interrupted = run_together(daemon, command=simulator_command(daemon, args.scenario, args.rate, duration,
                                                                     args.seed))
    except BaseException:  # e.g. the reader of the output gone (BrokenPipeError): the planner is stopped too
        daemon.close()
        raise
    progress.end()
    summary = summarise(daemon.records, daemon.plans, daemon.roster, [t.id for t in daemon.scenario.all_targets])
    counters = daemon.status(time.monotonic()).counters
    summary.update({"scenario": daemon.scenario.name, "planner": daemon.planner_name, "rate": args.rate,
                    "duration_s": duration, "interrupted": interrupted,
                    "navigation": "reported" if daemon.navigator is None else "skf",
                    "command_age_ms_median": daemon.engine.command_ages.median_ms(),
                    "command_age_ms_p99": daemon.engine.command_ages.p99_ms(),
                    "steps_released_by_timeout": counters.get("steps_released_by_timeout", 0),
                    "rejected": {k: v for k, v in counters.items() if k.startswith("rejected.")}})
    print_summary(summary, daemon.scenario.time.step_s)
    if args.json is not None:
        args.json.write_text(json.dumps(summary, indent=2))
    return 0  # run_command says "interrupted" and returns 130 when a signal stopped the run


def _print_header(daemon: Daemon, args: argparse.Namespace, duration: float) -> None:
    """What runs where: the scenario, the loopback ports, the live map's address."""
    (endpoint,) = daemon.zenoh_listening
    (mavlink,) = set(daemon.mavlink_bound.values())  # one port, shared by the vehicles
    print(f"demo: {daemon.scenario.name}, {len(daemon.scenario.vehicles)} UAVs, {duration:g} s at {args.rate:g}x; "
          f"zenoh {endpoint}, MAVLink {mavlink}", flush=True)
    live = daemon.live
    print(f"live map: {(live.url if live is not None else None) or 'off'}", flush=True)
    if live is not None and live.foxglove is not None:
        print(f"foxglove: {live.foxglove.url or 'no server'}" + (f", MCAP {args.foxglove_mcap}" if args.foxglove_mcap
                                                                else ""), flush=True)


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


def run_together(daemon: Daemon, command: list[str]) -> bool:
    """Run the simulator process and the daemon until the simulator ends; True if Ctrl-C or SIGTERM stopped them.

    The simulator's output goes to a temporary file (``gcs-demo-sim-vehicles-*.log`` in the system's
    temporary folder), removed when the simulator ends well or is stopped, kept (and named in the log)
    when it fails."""
    restore = stop_on_signals(daemon.stop)
    output = tempfile.NamedTemporaryFile("w", prefix="gcs-demo-sim-vehicles-", suffix=".log", delete=False)
    try:
        with output:
            simulator = subprocess.Popen(command, stdout=output, stderr=subprocess.STDOUT)
            finished: list[float] = []

            def done() -> bool:
                if simulator.poll() is not None and not finished:
                    finished.append(time.monotonic())
                return bool(finished) and time.monotonic() - finished[0] > 1.0  # let the last step through

            try:
                daemon.run(until=done)
            finally:
                _stop(simulator)
    finally:
        restore()
    interrupted = stopped_by() is not None
    if simulator.returncode in STOPPED_WELL or interrupted:
        Path(output.name).unlink(missing_ok=True)
    else:
        log.error("the simulated vehicles exited with status %s; their output is kept in %s", simulator.returncode,
                  output.name)
    return interrupted


def _stop(simulator: subprocess.Popen) -> None:
    """Stop the simulator as Ctrl-C would, and kill it if it does not end within 10 s."""
    if simulator.poll() is None:
        simulator.send_signal(signal.SIGINT)
        try:
            simulator.wait(timeout=10)
        except subprocess.TimeoutExpired:
            simulator.kill()
            simulator.wait()


