"""``gcs replay``'s command line: what to do with a recording (``--info``, ``--process``, ``--view``,
republish), its input checked before anything is read (:func:`check_replay`). The work is in
:mod:`gcs.recordings.replay` and :mod:`gcs.recordings.replay_view`."""

from __future__ import annotations

import argparse
import json
import sys
import threading
from pathlib import Path

from gcs.adapters.foxglove_out import FoxgloveMissing, add_foxglove_arguments, foxglove_options
from gcs.adapters.recording import RecordingError, check_mcap
from gcs.adapters.web import add_http_argument
from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, ZenohSettings, add_zenoh_arguments, required_settings
from gcs.cli_errors import UsageError, existing_file, one_line, positive, set_command, stop_on_signals, writable_file
from gcs.config.world import build_world
from gcs.adapters.engine_cli import (add_acceptance_arguments, add_federation_arguments, add_navigation_argument,
                                     federation_options)
from gcs.recordings.recorded_scenario import recording_contents, replay_scenario
from gcs.recordings.replay import (NS_PER_S, needs_world, process, republish, summarise, truth_error, truth_gospa,
                                    write_outputs)
from gcs.recordings.replay_view import cmd_view
from gcs.scenarios import DEFAULT_SCENARIO, load_scenario, scenario_base_dir
from protocols.errors import ProtocolError
from protocols.keys import validate_prefix

__all__ = ["add_replay", "check_replay"]


def add_replay(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs replay``."""
    parser = sub.add_parser("replay", help="summarise, republish or process a recording",
                            description="Republish a recording's inputs to Zenoh for a running daemon, or process "
                                        "them directly with the daemon's estimator (--process), or summarise them "
                                        "(--info). --process and --view use the scenario the recording names (the "
                                        "daemon's, or the one its vehicles announced) unless --scenario is given; "
                                        "a different one is a warning naming both. --process on a recording without "
                                        "any vehicle report is an error (exit status 1).")
    parser.add_argument("file", type=Path, metavar="FILE.mcap")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--info", action="store_true", help="print channels, counts, duration, vehicles and scenario")
    mode.add_argument("--process", action="store_true",
                      help="run the estimator on the file, without Zenoh, and print how many tracks it gave and its "
                           "counters (and the error against the recorded truth); --out writes the tracks, without "
                           "it they are not kept")
    mode.add_argument("--rate", type=float, default=1.0, help="republish R times faster than recorded (default 1)")
    mode.add_argument("--fast", action="store_true", help="republish as fast as possible")
    parser.add_argument("--scenario", default=None, metavar="NAME_OR_FILE",
                        help="scenario of the recorded run (--process, --view; default: the one the recording names, "
                             f"else {DEFAULT_SCENARIO})")
    parser.add_argument("--out", type=Path, metavar="TRACKS", help="--process: write tracks (.mcap or .csv)")
    parser.add_argument("--plan", action="store_true",
                        help="--process: also plan every step (every GA generation, no deadline); plans go to an "
                             ".mcap --out")
    parser.add_argument("--seed", type=int, default=0, help="--process --plan: the planner's seed (default 0)")
    add_navigation_argument(parser)
    add_acceptance_arguments(parser, "--process: ")
    add_federation_arguments(parser, "--process: ")
    parser.add_argument("--json", action="store_true", help="--info: print JSON")
    parser.add_argument("--view", action="store_true",
                        help="show the recording on the live map (play/pause, speed; --rate is the starting speed, "
                             "--scenario draws the city) until Ctrl-C")
    add_http_argument(parser, "the live map of --view")
    add_foxglove_arguments(parser)
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,))
    set_command(parser, _cmd_replay, check_replay)


def check_replay(args: argparse.Namespace) -> ZenohSettings | None:
    """``gcs replay``'s input, checked: the file is an MCAP recording, the options fit together, the scenario
    loads (:class:`~gcs.config.ScenarioError` otherwise); the zenoh settings when republishing, else None."""
    existing_file(args.file, "FILE")
    try:
        check_mcap(args.file)
    except RecordingError as error:
        raise UsageError(error) from None
    shown = args.view or args.foxglove_mcap is not None or args.foxglove is not None
    if shown and (args.info or args.process or args.fast):
        raise UsageError("--view and --foxglove-mcap cannot be combined with --info, --process or --fast")
    if args.foxglove is not None and not args.view:
        raise UsageError("--foxglove serves a replay live: add --view (or write a file with --foxglove-mcap)")
    if args.view and args.http is None and args.foxglove is None:
        raise UsageError("--view needs --http ADDRESS (or --foxglove ADDRESS)")
    if args.federation is not None and not args.process:
        raise UsageError("--federation replays a federation member's engine: add --process")
    if not args.fast:
        positive(args.rate, "--rate")
    positive(args.max_wait, "--max-wait")
    writable_file(args.out, "--out")
    writable_file(args.foxglove_mcap, "--foxglove-mcap")
    try:
        validate_prefix(args.prefix)
        foxglove_options(args)
    except (ProtocolError, FoxgloveMissing, ValueError) as error:
        raise UsageError(error) from None
    if shown or args.process:
        try:
            args.recorded = recording_contents(args.file)
        except RecordingError as error:
            raise UsageError(error) from None
        if args.scenario is not None:
            load_scenario(args.scenario)  # a bad --scenario is bad input, whatever the file holds
        if args.process and not args.recorded.has_report:
            return None  # nothing to process: said as the command runs
        args.scenario = replay_scenario(args.file, args.scenario, args.recorded.scenario)
        scenario = load_scenario(args.scenario)
        args.federation_options = federation_options(args, scenario.multitarget is not None, scenario.name)
    if shown or args.info or args.process:
        return None
    try:
        return required_settings(args, "republishing")
    except ValueError as error:
        raise UsageError(error) from None


def _cmd_replay(args: argparse.Namespace) -> int:
    settings = check_replay(args)
    try:
        if args.view or args.foxglove_mcap is not None or args.foxglove is not None:
            return cmd_view(args)
        if args.info:
            _print_info(summarise(args.file), args.json)
            return 0
        if args.process:
            if not args.recorded.has_report:
                print(f"gcs replay: error: {args.file} holds no vehicle report, so there are no tracks to estimate "
                      f"(gcs replay {args.file} --info lists what it holds)", file=sys.stderr)
                return 1
            _process(args)
            return 0
        stop = threading.Event()
        stop_on_signals(stop.set)
        counts = republish(args.file, settings, args.prefix, None if args.fast else args.rate, stop)
        print("republished " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
        return 0
    except RecordingError as error:  # the file is corrupt further in: bad input found late
        print(f"gcs replay: error: {one_line(error)}", file=sys.stderr)
        return 2
    except (RuntimeError, OSError) as error:
        print(f"gcs replay: error: {one_line(error)}", file=sys.stderr)
        return 1


def _print_info(info: dict, as_json: bool) -> None:
    if as_json:
        print(json.dumps(info, indent=2))
        return
    scenario = info["scenario"]
    named = f"scenario {scenario['name']} (fingerprint {scenario['fingerprint']})" if scenario else "no scenario named"
    print(f"{info['file']}: {info['messages']} messages over {info['duration_s']:.1f} s "
          f"(stamps span {info['stamp_span_s']:.1f} s); vehicles {', '.join(info['vehicles']) or '-'}; {named}"
          + ("" if info["reports"] else "; no vehicle report: --process has nothing to estimate from"))
    for channel in info["channels"]:
        print(f"  {channel['messages']:>8}  {channel['key']}  [{channel['encoding']}]")


def _process(args: argparse.Namespace) -> None:
    scenario = load_scenario(args.scenario)
    world = build_world(scenario, scenario_base_dir(args.scenario)) if args.plan or needs_world(scenario) else None
    tracks, plans, counters = process(args.file, scenario, args.prefix, world, args.seed, args.navigation,
                                      accept_unlisted=args.accept_unlisted, max_wait_s=args.max_wait, plan=args.plan,
                                      federation=args.federation_options)
    if args.out is not None:
        write_outputs(tracks, plans, args.out, args.prefix)
    print(f"{len(tracks)} track estimates" + (f" and {len(plans)} plan commands" if args.plan else "")
          + f" from {args.file}" + (f" -> {args.out}" if args.out else " (not kept: --out TRACKS.csv or .mcap writes "
                                                                        "them)") + "; "
          + ", ".join(f"{k} {v}" for k, v in sorted(counters.items())))
    step_ns = round(scenario.time.step_s * NS_PER_S)
    if scenario.multitarget is not None:
        mean, scored = truth_gospa(args.file, tracks, step_ns)
        if mean is not None:
            print(f"GOSPA mean {mean:.2f} m against every recorded truth over {scored} steps")
        return
    rmse, scored = truth_error(args.file, tracks, step_ns, scenario.target.id)
    if rmse is not None:
        print(f"RMSE against the recorded truth {rmse:.2f} m over {scored} tracks (--navigation {args.navigation})")
