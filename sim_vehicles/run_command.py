"""``sim-vehicles run``: argument parsing and wiring for the simulated vehicles."""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

from gcs.adapters.mavlink_wire import normalise_connection, read_signing_key, signing_key_from_passphrase
from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, ZenohSettings
from gcs.config import ScenarioError
from gcs.scenarios import DEFAULT_SCENARIO, load_scenario, scenario_base_dir
from gcs.world_loader import build_world
from protocols.keys import validate_prefix
from sim_vehicles.runner import DEFAULT_MAVLINK, Runner, RunOptions, install_signal_handlers

__all__ = ["add_run"]

log = logging.getLogger(__name__)


def _vehicle_connection(text: str) -> tuple[str, str]:
    vehicle_id, sep, connection = text.partition("=")
    if not sep or not vehicle_id or not connection:
        raise argparse.ArgumentTypeError(f"expected ID=CONNECTION, got {text!r}")
    return vehicle_id, normalise_connection(connection)


def add_run(sub: argparse._SubParsersAction) -> None:
    """Register ``sim-vehicles run``."""
    parser = sub.add_parser(
        "run", help="fly the scenario's vehicles and target; MAVLink peers and Zenoh publishers",
        description="Simulated fixed-wings (one MAVLink 2 system each) watching a ground target. Without a "
                    "ground station the vehicles loiter about their start points. Stop with Ctrl-C.")
    parser.add_argument("--scenario", default=DEFAULT_SCENARIO,
                        help=f"shipped name or .toml path (default {DEFAULT_SCENARIO})")
    parser.add_argument("--rate", type=float, default=1.0,
                        help="simulation seconds per wall-clock second; every timer scales with it (default 1)")
    parser.add_argument("--duration", type=float, default=None, metavar="S",
                        help="simulated seconds to run (default: until interrupted)")
    parser.add_argument("--seed", type=int, default=0, help="seed of every random stream (default 0)")
    parser.add_argument("--epoch-ns", type=int, default=None,
                        help="wire stamp of simulation time zero (default: now, whole seconds)")
    parser.add_argument("--mavlink", default=DEFAULT_MAVLINK, metavar="CONNECTION",
                        help=f"pymavlink connection string every vehicle uses (default {DEFAULT_MAVLINK}); "
                             "'none' disables MAVLink")
    parser.add_argument("--vehicle", action="append", type=_vehicle_connection, default=[], metavar="ID=CONNECTION",
                        help="a vehicle's own MAVLink endpoint (repeatable), e.g. uav2=udpin:127.0.0.1:14561")
    signing = parser.add_mutually_exclusive_group()
    signing.add_argument("--signing-passphrase", metavar="PASS",
                         help="sign MAVLink 2 with sha256(PASS), as MAVProxy's 'signing key PASS'")
    signing.add_argument("--signing-key-file", type=Path, metavar="FILE",
                         help="sign MAVLink 2 with a 32-byte key (raw or 64 hex characters)")
    parser.add_argument("--zenoh-mode", choices=["peer", "client", "none"], default="peer",
                        help="zenoh session mode; 'none' publishes nothing (default peer)")
    parser.add_argument("--zenoh-connect", action="append", default=None, metavar="ENDPOINT",
                        help=f"endpoint to connect to, repeatable (default {DEFAULT_ENDPOINT}, where gcs listens)")
    parser.add_argument("--zenoh-listen", action="append", default=[], metavar="ENDPOINT",
                        help="endpoint to listen on, repeatable (default none)")
    parser.add_argument("--prefix", default="gcs", help="zenoh key prefix (default gcs)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="write the closing summary as JSON")
    parser.set_defaults(handler=_cmd_run)


def _options(args: argparse.Namespace, vehicle_ids: list[str]) -> RunOptions:
    mavlink = None
    if args.mavlink.lower() != "none" or args.vehicle:
        default = None if args.mavlink.lower() == "none" else normalise_connection(args.mavlink)
        overrides = dict(args.vehicle)
        unknown = sorted(set(overrides) - set(vehicle_ids))
        if unknown:
            raise ValueError(f"--vehicle names unknown vehicles {unknown}; the scenario has {vehicle_ids}")
        missing = [v for v in vehicle_ids if v not in overrides and default is None]
        if missing:
            raise ValueError(f"--mavlink none leaves {missing} without an endpoint; give --vehicle for each")
        mavlink = {v: overrides.get(v, default) for v in vehicle_ids}
    key = None
    if args.signing_passphrase is not None:
        key = signing_key_from_passphrase(args.signing_passphrase)
    elif args.signing_key_file is not None:
        key = read_signing_key(args.signing_key_file)
    zenoh = None
    if args.zenoh_mode != "none":
        connect = tuple(args.zenoh_connect) if args.zenoh_connect is not None else (DEFAULT_ENDPOINT,)
        zenoh = ZenohSettings(mode=args.zenoh_mode, listen=tuple(args.zenoh_listen), connect=connect)
    validate_prefix(args.prefix)
    epoch = args.epoch_ns if args.epoch_ns is not None else (time.time_ns() // 1_000_000_000) * 1_000_000_000
    return RunOptions(rate=args.rate, duration_s=args.duration, seed=args.seed, epoch_ns=epoch, mavlink=mavlink,
                      signing_key=key, zenoh=zenoh, prefix=args.prefix)


def _cmd_run(args: argparse.Namespace) -> int:
    try:
        scenario = load_scenario(args.scenario)
        if not args.rate > 0:
            raise ValueError(f"--rate must be > 0, got {args.rate}")
        if args.duration is not None and not args.duration > 0:
            raise ValueError(f"--duration must be > 0, got {args.duration}")
        options = _options(args, [v.id for v in scenario.vehicles])
        base_dir = scenario_base_dir(args.scenario)
        world = build_world(scenario, base_dir)
        runner = Runner(scenario, world, options, base_dir=base_dir)
    except (ScenarioError, ValueError, OSError) as error:
        log.error("%s", error)
        return 2
    install_signal_handlers(runner)
    log.info("%s: %d vehicles at %gx real time%s", scenario.name, len(scenario.vehicles), options.rate,
             "" if options.duration_s is None else f" for {options.duration_s:g} s")
    try:
        summary = runner.run()
    except RuntimeError as error:  # e.g. a zenoh client with no router
        log.error("%s", error)
        return 1
    for line in summary.lines():
        print(line)
    if args.json is not None:
        args.json.write_text(json.dumps({
            "simulated_s": summary.simulated_s, "wall_s": summary.wall_s, "steps": summary.steps,
            "late_steps": summary.late_steps, "reports": dict(summary.reports),
            "detections": dict(summary.detections), "nav_reports": dict(summary.nav_reports),
            "modes": summary.modes, "mavlink": dict(summary.mavlink)}, indent=2))
    return 0
