"""``gcs run``: the daemon (``gcs status``, which asks a running one how it is, is in
:mod:`gcs.daemon.status_cli`, re-exported here)."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from gcs.adapters.engine_cli import (add_acceptance_arguments, add_federation_arguments, add_navigation_argument,
                                     federation_options)
from gcs.adapters.foxglove_out import FoxgloveMissing, add_foxglove_arguments, foxglove_options
from gcs.adapters.mavlink_cli import add_mavlink_arguments, connections_from_arguments, signing_key_from_arguments
from gcs.adapters.web import add_http_argument
from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, add_zenoh_arguments, required_settings
from gcs.adapters.mavlink_commands import DEFAULT_STREAM_RATE_HZ
from gcs.adapters.mavlink_takeover import HANDBACK_MODES, Takeover
from gcs.cli_errors import UsageError, one_line, positive, set_command, stop_on_signals, writable_file
from gcs.config.world import build_world
from gcs.daemon.app import Daemon
from gcs.daemon.options import DaemonOptions
from gcs.daemon.flight_report import FlightReport
from gcs.daemon.status_cli import add_status, format_status, query_status
from gcs.daemon.plan_runners import PLAN_RUNNERS, PLAN_PROCESS_NICENESS
from gcs.daemon.niceness import niceness_argument
from gcs.scenarios import DEFAULT_SCENARIO, load_scenario, scenario_base_dir
from gcs.core.planner_names import MULTITARGET_PLANNERS, PLANNERS
from protocols.errors import ProtocolError
from protocols.keys import validate_prefix

__all__ = ["add_run", "add_status", "query_status", "format_status", "DEFAULT_GCS_MAVLINK", "build_daemon",
           "check_run", "run_daemon"]

log = logging.getLogger(__name__)

DEFAULT_GCS_MAVLINK = "udpin:127.0.0.1:14550"
"""Where the daemon listens for vehicles unless told otherwise (the vehicles' default udpout)."""


def add_daemon_arguments(parser: argparse.ArgumentParser) -> None:
    """Options shared by ``gcs run`` and ``gcs demo``."""
    parser.add_argument("--scenario", default=DEFAULT_SCENARIO,
                        help=f"shipped name or .toml path (default {DEFAULT_SCENARIO})")
    parser.add_argument("--planner", choices=PLANNERS, default=None,
                        help="override the scenario's planner (ga_k5 is the paper's GA on k+5 predictions)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the planner's random generator (default 0)")
    parser.add_argument("--record", type=Path, metavar="FILE.mcap",
                        help="record everything received and published (MCAP), finished on exit")
    parser.add_argument("--plan-in", choices=PLAN_RUNNERS, default="process", dest="plan_runner",
                        help="where plans are made: a child process (default), a thread of the daemon, or inline "
                             "in its loop (deterministic; the loop waits for each plan)")
    parser.add_argument("--planner-nice", type=niceness_argument, default=PLAN_PROCESS_NICENESS,
                        dest="plan_process_niceness",
                        metavar="N", help=f"how much lower the planner process's priority is, 0-19 (default "
                                          f"{PLAN_PROCESS_NICENESS}; 19: the loop first when reports flood in, at the "
                                          "price of plans cut short on a busy machine)")
    add_http_argument(parser, "the live map (vehicles, track, plans, status)")
    add_foxglove_arguments(parser)
    add_acceptance_arguments(parser)
    add_navigation_argument(parser)
    add_control_arguments(parser)


def add_control_arguments(parser: argparse.ArgumentParser) -> None:
    """How the daemon takes vehicles over and gives them back, and the telemetry rate it asks for."""
    parser.add_argument("--stream-rate", type=float, default=DEFAULT_STREAM_RATE_HZ, metavar="HZ",
                        help=f"ask every vehicle for GLOBAL_POSITION_INT and ATTITUDE at this rate (default "
                             f"{DEFAULT_STREAM_RATE_HZ:g}; ArduPlane sends 1 Hz until asked); 0 asks nothing")
    parser.add_argument("--takeover-altitude", type=float, default=Takeover().min_altitude_m, metavar="M",
                        help="switch a vehicle to GUIDED only when it is armed and at least this high above home "
                             f"(default {Takeover().min_altitude_m:g} m)")
    parser.add_argument("--handback", choices=HANDBACK_MODES, default=Takeover().handback,
                        help="the mode a vehicle is given back in when the daemon stops or loses the target "
                             f"(default {Takeover().handback})")
    parser.add_argument("--takeoff", action="store_true",
                        help="arm a vehicle that is disarmed or below --takeover-altitude and take it off with its "
                             "autopilot's own take-off mode (ArduPlane TAKEOFF to TKOFF_ALT, PX4 AUTO.TAKEOFF) "
                             "before switching it to GUIDED (default: wait for the pilot to do so)")
    parser.add_argument("--handback-after", type=float, default=60.0, metavar="S",
                        help="give the vehicles back after this many seconds with no vehicle seeing the target "
                             "(default 60); they are taken again when it is seen")


def _control_options(args: argparse.Namespace) -> dict:
    """The DaemonOptions fields of :func:`add_control_arguments`, checked (UsageError naming the option)."""
    if not 0.0 <= args.stream_rate <= 50.0:
        raise UsageError(f"--stream-rate must be between 0 and 50 Hz, got {args.stream_rate:g}")
    if not -1000.0 <= args.takeover_altitude <= 10_000.0:
        raise UsageError(f"--takeover-altitude must be a height in metres above home (-1000 to 10000), "
                         f"got {args.takeover_altitude:g}")
    positive(args.handback_after, "--handback-after")
    return {"stream_rate_hz": args.stream_rate, "handback_after_lost_s": args.handback_after,
            "takeover": Takeover(min_altitude_m=args.takeover_altitude, handback=args.handback,
                                 takeoff=args.takeoff)}


def add_run(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs run``."""
    parser = sub.add_parser(
        "run", help="the ground-station daemon: reports in over Zenoh, headings out over MAVLink",
        description="Fuse the vehicles' reports, predict the target, plan every vehicle's heading and command "
                    "it over MAVLink; publish tracks and plans over Zenoh. Logs a line of status every 30 s of "
                    "flight, and what it did when stopped (Ctrl-C or SIGTERM). docs/cli.md explains the output.")
    add_daemon_arguments(parser)
    add_mavlink_arguments(parser, DEFAULT_GCS_MAVLINK, "every vehicle is reached through")
    add_zenoh_arguments(parser, listen=(DEFAULT_ENDPOINT,), connect=())
    add_federation_arguments(parser)
    set_command(parser, _cmd_run, check_run)


def build_daemon(args: argparse.Namespace, **kwargs) -> Daemon:
    """The daemon the parsed options describe, built but not opened: :class:`UsageError` naming the option for
    bad input (:class:`~gcs.config.ScenarioError` for a scenario that does not load)."""
    scenario = load_scenario(args.scenario)
    if scenario.multitarget is not None and args.planner is not None and args.planner not in MULTITARGET_PLANNERS:
        raise UsageError(f"--planner: {args.planner} cannot share the UAVs between the targets of {scenario.name} "
                         f"([multitarget]); use one of {', '.join(MULTITARGET_PLANNERS)}")
    try:
        validate_prefix(args.prefix)
    except ProtocolError as error:
        raise UsageError(f"--prefix: {error}") from None
    writable_file(args.record, "--record")
    federation = federation_options(args, scenario.multitarget is not None, scenario.name)
    try:
        zenoh = required_settings(args, "the daemon")
        mavlink = connections_from_arguments(args, [v.id for v in scenario.vehicles])
        options = DaemonOptions(zenoh=zenoh, prefix=args.prefix, mavlink=mavlink,
                                signing_key=signing_key_from_arguments(args), seed=args.seed, planner=args.planner,
                                record=args.record, plan_runner=args.plan_runner,
                                plan_process_niceness=args.plan_process_niceness, http=args.http,
                                foxglove=foxglove_options(args), accept_unlisted=args.accept_unlisted,
                                max_wait_s=positive(args.max_wait, "--max-wait"),
                                navigation=args.navigation, federation=federation, **_control_options(args))
    except (ValueError, FoxgloveMissing) as error:
        raise UsageError(error) from None
    base_dir = scenario_base_dir(args.scenario)
    return Daemon(scenario, build_world(scenario, base_dir), options, **kwargs)


def check_run(args: argparse.Namespace):
    """``gcs run``'s input, checked: the daemon it describes (not opened)."""
    return build_daemon(args)


def run_daemon(daemon, command: str, until=None) -> int:
    """Run ``daemon`` (opening it first) until stopped: 0, or 1 with one line on stderr when what it must open
    cannot be (a zenoh client without its router, a port another program holds, a file it cannot write)."""
    try:
        daemon.run(until=until)
    except (RuntimeError, OSError, ValueError) as error:
        print(f"{command}: error: {one_line(error)}", file=sys.stderr)
        return 1
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    daemon = check_run(args)
    report = FlightReport(lambda: daemon.status(daemon.clock()), daemon.scenario.time.step_s)
    daemon.on_step = report
    stop_on_signals(daemon.stop)
    status = run_daemon(daemon, "gcs run")
    if status == 0:
        log.info("%s", report.stopped(daemon.status(daemon.clock()).counters, daemon.options.mavlink is not None))
    return status
