"""``gcs-bench``'s parsers of the ground station as a system: daemon, replay, livemap, soak, autopilots and demo
(:mod:`benchmarks.commands` runs them)."""

from __future__ import annotations

import argparse
from pathlib import Path

from benchmarks import PLANNERS, commands
from benchmarks.arguments import (PLOTS_HELP, finish, non_negative_int, outputs_checked, positive_float,
                                  positive_int)
from gcs.daemon.niceness import niceness_argument

__all__ = ["add_daemon", "add_replay", "add_livemap", "add_soak", "add_autopilots", "add_demo"]

DAEMON_NAVIGATION = ("auto", "skf", "reported")
"""The daemon's ``--navigation`` choices (:data:`gcs.engine.navigation.NAVIGATION_MODES`, not imported: the
parser stays light)."""

LOAD_NICENESS = 5
"""``gcs-bench daemon --load-nice``'s default (:data:`benchmarks.daemon_load.LOAD_NICENESS`, not imported either)."""

def add_daemon(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench daemon``."""
    dmn = sub.add_parser(
        "daemon",
        help="the daemon over Zenoh: report-to-command latency and the highest report rate with no loss",
        description="Feeds the daemon (real Zenoh on 127.0.0.1, no MAVLink) sensor reports from a separate "
                    "process for 10, 50 and 100 vehicles, searches the highest aggregate report rate it keeps "
                    "up with and nothing dropped, and measures report-to-command latency without the planner's "
                    "solve time (orbit planner), then the GA's solve time with reports in real time.",
    )
    dmn.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    dmn.add_argument("--vehicles", type=positive_int, nargs="+", default=[10, 50, 100], metavar="N",
                     help="vehicle counts to measure (default 10 50 100)")
    dmn.add_argument("--seconds", type=positive_float, default=3.0, help="seconds per rate trial (default 3)")
    dmn.add_argument("--rates", type=positive_float, nargs="+", metavar="R",
                     help="instead of searching, one trial at each of these reports/s in turn (e.g. 5000 5000 "
                          "5000 to see how the latency at the goal varies)")
    dmn.add_argument("--solve-steps", type=non_negative_int, default=5,
                     help="real-time decision steps to time the GA's solve over, 0 to skip (default 5)")
    dmn.add_argument("--navigation", choices=DAEMON_NAVIGATION, default="auto",
                     help="the daemon's --navigation (default auto, as gcs run); when it runs the SKF the load "
                          "sends a NavReport per vehicle per round beside its sensor report (GPS fix; not counted "
                          "in the rate)")
    dmn.add_argument("--load-nice", type=niceness_argument, default=LOAD_NICENESS, dest="load_niceness", metavar="N",
                     help=f"how much lower the load process's priority is, 0-19 (default {LOAD_NICENESS}: the "
                          "vehicles' own computers in use; 0 shares the CPUs with the daemon evenly)")
    dmn.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    dmn.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    dmn.add_argument("--profile", type=Path, metavar="FILE",
                     help="profile the daemon's loop (cProfile) during the rate searches and write the stats to FILE")
    dmn.set_defaults(handler=outputs_checked(commands.cmd_daemon))
    finish(dmn)


def add_replay(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench replay``."""
    rpl = sub.add_parser(
        "replay", help="gcs replay --process speed in multiples of real time (goal 1000x)",
        description="Simulates the scenario's reports into an MCAP file, then times the estimator on it "
                    "(gcs replay --process, reading included) and reports the speed in multiples of real time.")
    rpl.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    rpl.add_argument("--duration", type=positive_float, default=300.0, help="simulated seconds (default 300)")
    rpl.add_argument("--repeats", type=positive_int, default=5, help="timed runs; the median is reported (default 5)")
    rpl.add_argument("--seed", type=int, default=0, help="seed of the simulated scene (default 0)")
    rpl.add_argument("--navigation", choices=DAEMON_NAVIGATION, default="auto",
                     help="replay --process's --navigation: auto (default: skf if the scenario declares GPS-denied "
                          "zones, else reported), skf (each vehicle's SKF on its nav reports) or reported")
    rpl.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    rpl.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    rpl.set_defaults(handler=outputs_checked(commands.cmd_replay))
    finish(rpl)


def add_livemap(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench livemap``."""
    lmp = sub.add_parser(
        "livemap", help="what the live map costs the daemon's loop: per message and per snapshot",
        description="Feeds the live map's picture the messages of 3, 10 and 100 vehicles (nav with GPS at 5 Hz, "
                    "reports, plans, a track and the truth each step) until the trails are full, then times "
                    "observing each message against the codec's decoding of it, and the snapshots.")
    lmp.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    lmp.add_argument("--vehicles", type=positive_int, nargs="+", default=[3, 10, 100], metavar="N",
                     help="team sizes (default 3 10 100)")
    lmp.add_argument("--warm-up", type=positive_int, default=600, metavar="S",
                     help="simulated seconds fed before measuring, to fill the trails (default 600)")
    lmp.add_argument("--seconds", type=positive_int, default=20, metavar="S",
                     help="simulated seconds measured (default 20)")
    lmp.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    lmp.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    lmp.set_defaults(handler=outputs_checked(commands.cmd_livemap))
    finish(lmp)


def add_soak(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench soak``."""
    soak = sub.add_parser(
        "soak", help="the whole ground station for a long run with random faults: nothing lost, no crash, memory",
        description="Runs a router, the daemon and simulated vehicle processes on 127.0.0.1 for a long simulated "
                    "run, killing and restarting vehicle processes, silencing MAVLink links and injecting bad "
                    "samples at random; reports the samples published vs those the daemon took in (accepted or "
                    "rejected by reason), crashes, and the daemon's memory. Exit 1 if anything was lost or crashed.")
    soak.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    soak.add_argument("--vehicles", type=positive_int, default=10, help="simulated vehicles (default 10)")
    soak.add_argument("--processes", type=positive_int, default=5,
                      help="vehicle processes, the vehicles shared among them (default 5)")
    soak.add_argument("--duration", type=positive_float, default=1800.0, help="simulated seconds (default 1800)")
    soak.add_argument("--rate", type=positive_float, default=20.0,
                      help="simulated seconds per wall second (default 20)")
    soak.add_argument("--fault-every", type=positive_float, default=3.0, metavar="S",
                      help="mean wall seconds between faults (default 3)")
    soak.add_argument("--planner", choices=PLANNERS, default=None, help="the daemon's planner (default the scenario's)")
    soak.add_argument("--seed", type=int, default=0, help="seed of the vehicles and of the faults (default 0)")
    soak.add_argument("--workdir", type=Path, metavar="DIR", help="where the logs go (default a temporary folder)")
    soak.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    soak.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    soak.set_defaults(handler=outputs_checked(commands.cmd_soak))
    finish(soak)


def add_autopilots(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench autopilots``."""
    aps = sub.add_parser(
        "autopilots", help="the daemon's steering flown by each autopilot personality: course error, seen, RMSE",
        description="Flies the scenario in one process on paired seeds under each simulated autopilot "
                    "personality (ideal, arduplane, px4), with the daemon's own telemetry handling, steering "
                    "and MAVLink encoding, every message packed and parsed as on the wire, and prints per "
                    "personality the course error against the planned path (median and p90 after a 10 s "
                    "settle), seen by any UAV and per UAV, RMSE, their ratios to the ideal airframe and the "
                    "paired Wilcoxon p of seen-by-any against it.")
    aps.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    aps.add_argument("--runs", type=positive_int, default=10, help="paired seeds per personality (default 10)")
    aps.add_argument("--seed", type=int, default=2012, help="seed of the first run (default 2012)")
    aps.add_argument("--duration", type=positive_float, help="seconds of flight per run (default: the scenario's)")
    aps.add_argument("--autopilot", action="append", choices=["ideal", "arduplane", "px4"],
                     help="personality to fly (repeatable; default all three)")
    aps.add_argument("--compare-pursuit", action="store_true",
                     help="also fly every personality steered by pursuit of a point 4 s on the plan, without lead")
    aps.add_argument("--identify", action="store_true",
                     help="also print each personality's course loop identified from step responses (with --sitl: "
                          "the real ArduPlane's, and the personality fitted to it)")
    aps.add_argument("--sitl", metavar="PATH",
                     help="fly the real ArduPlane (an ArduPilot SITL binary, 'arduplane', run in a network "
                          "namespace of its own, in real time) beside the arduplane personality on the same seeds")
    aps.add_argument("--workers", type=positive_int, default=1, help="processes to fly the seeds in (default 1)")
    aps.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    aps.set_defaults(handler=outputs_checked(commands.cmd_autopilots), autopilot=None)
    finish(aps)


def add_demo(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench demo``."""
    dem = sub.add_parser(
        "demo", help="gcs demo at its default settings against the same scenario and seeds in one process",
        description="For each seed, runs gcs demo (the daemon and sim-vehicles on loopback) and the in-process "
                    "loop of gcs-bench autopilots on the same scene, and prints the means of seen-by-any, per UAV "
                    "and RMSE of both, with the demo's ratios to the in-process loop.")
    dem.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    dem.add_argument("--runs", type=positive_int, default=5, help="seeds (default 5)")
    dem.add_argument("--seed", type=int, default=0, help="the first seed (default 0, gcs demo's)")
    dem.add_argument("--rate", type=positive_float, help="the demo's speed-up (default: gcs demo's)")
    dem.add_argument("--duration", type=positive_float, help="simulated seconds per run (default: the scenario's)")
    dem.add_argument("--wait-for-plans", action="store_true",
                     help="run the vehicles with sim-vehicles run --wait-for-plans (default: as gcs demo, without)")
    dem.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    dem.set_defaults(handler=outputs_checked(commands.cmd_demo))
    finish(dem)
