"""``sim-vehicles run``: argument parsing and wiring for the simulated vehicles."""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path

from gcs.adapters.mavlink_cli import add_mavlink_arguments, connections_from_arguments, signing_key_from_arguments
from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, add_zenoh_arguments, settings_from_arguments
from gcs.cli_errors import UsageError, one_line, positive, set_command, stop_on_signals, writable_file
from gcs.config.world import build_world
from gcs.scenarios import DEFAULT_SCENARIO, load_scenario, scenario_base_dir
from protocols.errors import ProtocolError
from protocols.keys import validate_prefix
from sim_vehicles.run_options import RunOptions
from sim_vehicles.runner import DEFAULT_MAVLINK, Runner

__all__ = ["add_run", "add_scenario_argument", "check_run"]

log = logging.getLogger(__name__)


def add_run(sub: argparse._SubParsersAction) -> None:
    """Register ``sim-vehicles run``."""
    parser = sub.add_parser(
        "run", help="fly the scenario's vehicles and target; MAVLink peers and Zenoh publishers",
        description="Simulated fixed-wings (one MAVLink 2 system each) watching a ground target. Without a "
                    "ground station the vehicles loiter about their start points. Stop with Ctrl-C.")
    add_scenario_argument(parser)
    parser.add_argument("--rate", type=float, default=1.0,
                        help="simulation seconds per wall-clock second; every timer scales with it (default 1)")
    parser.add_argument("--duration", type=float, default=None, metavar="S",
                        help="simulated seconds to run (default: until interrupted)")
    parser.add_argument("--seed", type=int, default=0, help="seed of every random stream (default 0)")
    parser.add_argument("--epoch-ns", type=int, default=None,
                        help="wire stamp of simulation time zero (default: now, whole seconds)")
    add_mavlink_arguments(parser, DEFAULT_MAVLINK, "every vehicle")
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,))
    parser.add_argument("--only", action="append", default=None, metavar="ID",
                        help="fly only this vehicle (repeatable), e.g. one process per vehicle; the target is "
                             "simulated in each, with the same seed the same target")
    parser.add_argument("--wait-for-gcs", type=float, default=5.0, metavar="S",
                        help="wait up to S wall seconds for a subscriber to the reports before starting, so the "
                             "first reports are not lost while the connection comes up (default 5; 0: don't)")
    parser.add_argument("--start-at", type=float, default=None, metavar="UNIX_TIME",
                        help="start the simulation clock at this Unix time (seconds), e.g. to keep vehicles flown "
                             "by several processes on one clock; a time already past joins that clock (a restarted "
                             "vehicle process: the scene is advanced to it first, --duration counts from zero)")
    parser.add_argument("--start-with", action="append", default=[], metavar="ID",
                        help="start the simulation clock once vehicle ID, flown by another process started the same "
                             "way, has come up on zenoh (repeatable), however long the machine takes to start them: "
                             "e.g. --only uav1 --start-with uav2 --start-with uav3 (needs Zenoh on which the processes hear "
                             "each other, e.g. clients of one router; not with --start-at)")
    parser.add_argument("--lockstep", action="store_true",
                        help="keep one clock with the other simulated vehicles under the prefix (other processes): "
                             "hold while more than one report ahead of the slowest, so that a machine that cannot "
                             "keep the rate slows the run down as a whole instead of letting the processes drift "
                             "apart (needs Zenoh)")
    parser.add_argument("--wait-for-plans", action="store_true",
                        help="hold each step until the ground station's plan of the decision step reached has come "
                             "(at most 0.5 s of wall time), as a simulator in lockstep with its controller: commands "
                             "are then never flown later than in the daemon's own loop (needs Zenoh; not for real "
                             "time against real vehicles)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="write the closing summary as JSON")
    set_command(parser, _cmd_run, check_run)


def add_scenario_argument(parser: argparse.ArgumentParser) -> None:
    """``--scenario NAME|PATH``, as every ``sim-vehicles`` subcommand takes it."""
    parser.add_argument("--scenario", default=DEFAULT_SCENARIO,
                        help=f"shipped name or .toml path (default {DEFAULT_SCENARIO})")


def _options(args: argparse.Namespace, vehicle_ids: list[str]) -> RunOptions:
    try:
        validate_prefix(args.prefix)
    except ProtocolError as error:
        raise UsageError(f"--prefix: {error}") from None
    try:
        mavlink = connections_from_arguments(args, vehicle_ids)
        key = signing_key_from_arguments(args)
        zenoh = settings_from_arguments(args)
    except ValueError as error:
        raise UsageError(error) from None
    if args.wait_for_plans and zenoh is None:
        raise UsageError("--wait-for-plans hears the plans over zenoh: not with --zenoh-mode none")
    if args.lockstep and zenoh is None:
        raise UsageError("--lockstep keeps the clock with the other vehicles over zenoh: not with --zenoh-mode none")
    if args.start_with and zenoh is None:
        raise UsageError("--start-with hears the other vehicles over zenoh: not with --zenoh-mode none")
    if args.start_with and args.start_at is not None:
        raise UsageError("--start-with and --start-at both say when the clock starts: give one")
    if args.start_at is not None and not abs(args.start_at) < 1e11:
        raise UsageError(f"--start-at is a Unix time in seconds, got {args.start_at:g}")
    epoch = args.epoch_ns if args.epoch_ns is not None else (time.time_ns() // 1_000_000_000) * 1_000_000_000
    return RunOptions(rate=args.rate, duration_s=args.duration, seed=args.seed, epoch_ns=epoch, mavlink=mavlink,
                      signing_key=key, zenoh=zenoh, prefix=args.prefix,
                      only=None if args.only is None else tuple(args.only), wait_for_subscriber_s=args.wait_for_gcs,
                      start_at_ns=None if args.start_at is None else round(args.start_at * 1e9),
                      start_with=tuple(args.start_with), lockstep=args.lockstep, wait_for_plans=args.wait_for_plans)


def check_run(args: argparse.Namespace) -> Runner:
    """``sim-vehicles run``'s input, checked: the runner it describes (nothing opened)."""
    scenario = load_scenario(args.scenario)
    positive(args.rate, "--rate")
    positive(args.duration, "--duration")
    if not 0.0 <= args.wait_for_gcs < float("inf"):
        raise UsageError(f"--wait-for-gcs must be a number of seconds >= 0, got {args.wait_for_gcs:g}")
    writable_file(args.json, "--json")
    known = [v.id for v in scenario.vehicles]
    unknown = sorted(set(args.only or ()) - set(known))
    if unknown:
        raise UsageError(f"--only {', '.join(unknown)}: not in the scenario, whose vehicles are {', '.join(known)}")
    flown = [v for v in known if args.only is None or v in args.only]
    for vehicle in args.start_with:
        if vehicle not in known or vehicle in flown:
            raise UsageError(f"--start-with {vehicle}: not a vehicle of the scenario flown by another process "
                             f"({', '.join(v for v in known if v not in flown) or 'none: this process flies all'})")
    options = _options(args, flown)
    base_dir = scenario_base_dir(args.scenario)
    return Runner(scenario, build_world(scenario, base_dir), options, base_dir=base_dir)


def _cmd_run(args: argparse.Namespace) -> int:
    runner = check_run(args)
    options = runner.options
    stop_on_signals(runner.stop)
    log.info("%s: %d vehicles at %gx real time%s", runner.scenario.name, len(runner.vehicles), options.rate,
             "" if options.duration_s is None else f" for {options.duration_s:g} s")
    try:
        summary = runner.run()
    except (RuntimeError, OSError, ValueError) as error:  # e.g. a zenoh client with no router, a port in use
        print(f"sim-vehicles run: error: {one_line(error)}", file=sys.stderr)
        return 1
    for line in summary.lines():
        print(line)
    if args.json is not None:
        args.json.write_text(json.dumps({
            "simulated_s": summary.simulated_s, "wall_s": summary.wall_s, "steps": summary.steps,
            "late_steps": summary.late_steps, "held_steps": summary.held_steps, "held_s": summary.held_s,
            "reports": dict(summary.reports), "detections": dict(summary.detections),
            "nav_reports": dict(summary.nav_reports), "modes": summary.modes, "mavlink": dict(summary.mavlink)},
            indent=2))
    return 0
