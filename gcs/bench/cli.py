"""``gcs bench ...``: the argument parser of each benchmark (:mod:`gcs.bench.commands` runs them).

Each benchmark module computes; this module declares the arguments and checks ``--json`` and
``--plots`` before a benchmark runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gcs.bench import PLANNERS, SEARCH_VARIANTS, commands
from gcs.bench.urban_nav import NAVIGATION_MODES
from gcs.cli_errors import UsageError, writable_file
from gcs.daemon.niceness import niceness_argument

DAEMON_NAVIGATION = ("auto", "skf", "reported")
"""The daemon's ``--navigation`` choices (:data:`gcs.engine.navigation.NAVIGATION_MODES`, not imported: the
parser stays light)."""

LOAD_NICENESS = 5
"""``gcs bench daemon --load-nice``'s default (:data:`gcs.bench.daemon_load.LOAD_NICENESS`, not imported either)."""

PLOTS_HELP = "write PNG plots and a markdown table (<benchmark>.md) into DIR"


def _check_outputs(args: argparse.Namespace) -> None:
    """UsageError unless --json can be written and --plots DIR is a folder or can be made; the scenario loads."""
    writable_file(getattr(args, "json", None), "--json")
    plots = getattr(args, "plots", None)
    if plots is not None and plots.exists() and not plots.is_dir():
        raise UsageError(f"--plots {plots}: not a folder")
    if getattr(args, "scenario", None) is not None:
        from gcs.scenarios import load_scenario

        load_scenario(args.scenario)


def _outputs_checked(handler):
    """Check --json and --plots DIR (made here) before the benchmark runs, not after an hour of it."""

    def checked(args: argparse.Namespace) -> int:
        _check_outputs(args)
        plots = getattr(args, "plots", None)
        if plots is not None:
            try:
                plots.mkdir(parents=True, exist_ok=True)
            except OSError as error:
                raise UsageError(f"--plots {plots}: {error.strerror or error}") from None
        return handler(args)

    return checked


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _non_negative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def _probability(text: str) -> float:
    value = float(text)
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a probability in (0, 1], got {text}")
    return value


def _non_negative_float(text: str) -> float:
    value = float(text)
    if not 0.0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value


def add_bench(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs bench`` and its benchmarks."""
    parser = sub.add_parser("bench", help="reproduce the papers' experiments and measure speed",
                            description="Benchmarks: each prints its table (progress on stderr) and can write --json, and "
                                "--plots DIR: PNG plots and the tables in markdown.")
    parser.set_defaults(check=_check_outputs)
    benches = parser.add_subparsers(dest="bench", required=True, metavar="BENCHMARK")
    est = benches.add_parser(
        "estimation",
        help="DUIF vs FilterPy's UKF: RMSE, RMSE/sqrt(PCRLB), NEES, microseconds per step",
        description="Feeds the same generated data (wang2012's sensor set-up, vehicles loitering around "
                    "the target) to our DUIF and to FilterPy's UnscentedKalmanFilter with every vehicle "
                    "stacked, and reports accuracy against the PCRLB and speed, plus a table for "
                    "1, 3, 10 and 30 vehicles.",
    )
    est.add_argument("--runs", type=_positive_int, default=100, help="Monte Carlo runs with 3 vehicles (default 100)")
    est.add_argument("--steps", type=_positive_int, default=100, help="1 s steps per run (default 100)")
    est.add_argument("--table-runs", type=_positive_int, default=5, help="runs per row of the vehicle-count table (default 5)")
    est.add_argument("--seed", type=int, default=2012, help="seed of the generated data (default 2012)")
    est.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    est.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    est.set_defaults(handler=_outputs_checked(commands.cmd_estimation))

    urb = benches.add_parser(
        "urban",
        help="closed loop in the city: observations, RMSE, airspace violations and decision time per planner",
        description="Runs the closed loop (truth target, occluded sensing, DUIF, k+n prediction, planning, "
                    "UAVs flying the first command) on paired seeds for each planner and prints, per planner, "
                    "the steps seen by any UAV and per UAV, RMSE, runs that lost the track, airspace violations, "
                    "decision times and paired Wilcoxon p-values against the orbit and k+0; then the decision "
                    "time of the sight planner and of wang2012's GA for 3, 6, 10 and 20 UAVs. Shipped "
                    "scenarios: wang2012_urban, downtown_dense, nofly_city, fast_target (gcs scenario list).",
    )
    urb.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    urb.add_argument("--runs", type=_positive_int, default=10, help="paired runs per planner (default 10)")
    urb.add_argument("--seed", type=int, default=2012, help="seed of the first run (default 2012)")
    urb.add_argument("--planners", nargs="+", action="extend", choices=PLANNERS + SEARCH_VARIANTS, metavar="PLANNER",
                     help=f"planners to run (default: {', '.join(PLANNERS)}; also {', '.join(SEARCH_VARIANTS)}, "
                          "the sight objective searched otherwise)")
    urb.add_argument("--planner", action="append", choices=PLANNERS + SEARCH_VARIANTS, dest="planners",
                     help=argparse.SUPPRESS)
    urb.add_argument("--duration", type=_positive_float, help="seconds of simulation per run (default: the scenario's)")
    urb.add_argument("--motion", choices=["white_noise_acceleration", "streets"],
                     help="target motion (default: the scenario's)")
    urb.add_argument("--workers", type=_positive_int, default=1,
                     help="run the seeds in this many processes (default 1); results are the same whatever the number")
    urb.add_argument("--dask", metavar="ADDRESS",
                     help="run the seeds on the Dask cluster whose scheduler is at ADDRESS, e.g. tcp://127.0.0.1:8786 "
                          "(needs the cluster extra: pip install .[cluster])")
    urb.add_argument("--no-scaling", action="store_true", help="skip the 3/6/10/20-UAV timing table")
    urb.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    urb.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    urb.add_argument("--gps-denied", action="store_true",
                     help="GPS-denied zones (the scenario's, else a 1.5 km square about the target's start): target "
                          "RMSE with the vehicles' own navigation (perfect, raw GPS, SKF); planner default ga_k5")
    urb.add_argument("--navigation", action="append", choices=NAVIGATION_MODES,
                     help="with --gps-denied: navigation to run (repeatable; default all)")
    urb.set_defaults(handler=_outputs_checked(commands.cmd_urban), planners=None, navigation=None)

    dmn = benches.add_parser(
        "daemon",
        help="the daemon over Zenoh: report-to-command latency and the highest report rate with no loss",
        description="Feeds the daemon (real Zenoh on 127.0.0.1, no MAVLink) sensor reports from a separate "
                    "process for 10, 50 and 100 vehicles, searches the highest aggregate report rate it keeps "
                    "up with and nothing dropped, and measures report-to-command latency without the planner's "
                    "solve time (orbit planner), then the GA's solve time with reports in real time.",
    )
    dmn.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    dmn.add_argument("--vehicles", type=_positive_int, nargs="+", default=[10, 50, 100], metavar="N",
                     help="vehicle counts to measure (default 10 50 100)")
    dmn.add_argument("--seconds", type=_positive_float, default=3.0, help="seconds per rate trial (default 3)")
    dmn.add_argument("--rates", type=_positive_float, nargs="+", metavar="R",
                     help="instead of searching, one trial at each of these reports/s in turn (e.g. 5000 5000 "
                          "5000 to see how the latency at the goal varies)")
    dmn.add_argument("--solve-steps", type=_non_negative_int, default=5,
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
    dmn.set_defaults(handler=_outputs_checked(commands.cmd_daemon))

    rpl = benches.add_parser(
        "replay", help="gcs replay --process speed in multiples of real time (goal 1000x)",
        description="Simulates the scenario's reports into an MCAP file, then times the estimator on it "
                    "(gcs replay --process, reading included) and reports the speed in multiples of real time.")
    rpl.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    rpl.add_argument("--duration", type=_positive_float, default=300.0, help="simulated seconds (default 300)")
    rpl.add_argument("--repeats", type=_positive_int, default=5, help="timed runs; the median is reported (default 5)")
    rpl.add_argument("--seed", type=int, default=0, help="seed of the simulated scene (default 0)")
    rpl.add_argument("--navigation", choices=DAEMON_NAVIGATION, default="auto",
                     help="replay --process's --navigation: auto (default: skf if the scenario declares GPS-denied "
                          "zones, else reported), skf (each vehicle's SKF on its nav reports) or reported")
    rpl.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    rpl.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    rpl.set_defaults(handler=_outputs_checked(commands.cmd_replay))

    aoa = benches.add_parser(
        "aoa", help="zuo2021 bearing-only tracking: estimators, GCRLB-LM vs CRLB vs straight-line planners",
        description="Reproduces zuo2021 section 5 over paired runs: estimator MSE on straight flight (Fig. 2), "
                    "the closed loop with the GCRLB-LM, Dogancay CRLB-LM and straight-line planners (Figs. 3-6), "
                    "2-6 sensors (Fig. 7) and unequal sensor accuracies 1 / 0.8 / 0.1 deg (Fig. 8).")
    aoa.add_argument("--runs", type=_positive_int, default=50, help="paired Monte Carlo runs (default 50)")
    aoa.add_argument("--steps", type=_positive_int, default=100, help="1 s steps per run (default 100)")
    aoa.add_argument("--seed", type=int, default=2021, help="seed of the first run (default 2021)")
    aoa.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    aoa.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    aoa.set_defaults(handler=_outputs_checked(commands.cmd_aoa))

    lmp = benches.add_parser(
        "livemap", help="what the live map costs the daemon's loop: per message and per snapshot",
        description="Feeds the live map's picture the messages of 3, 10 and 100 vehicles (nav with GPS at 5 Hz, "
                    "reports, plans, a track and the truth each step) until the trails are full, then times "
                    "observing each message against the codec's decoding of it, and the snapshots.")
    lmp.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    lmp.add_argument("--vehicles", type=_positive_int, nargs="+", default=[3, 10, 100], metavar="N",
                     help="team sizes (default 3 10 100)")
    lmp.add_argument("--warm-up", type=_positive_int, default=600, metavar="S",
                     help="simulated seconds fed before measuring, to fill the trails (default 600)")
    lmp.add_argument("--seconds", type=_positive_int, default=20, metavar="S",
                     help="simulated seconds measured (default 20)")
    lmp.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    lmp.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    lmp.set_defaults(handler=_outputs_checked(commands.cmd_livemap))

    from gcs.bench.skf_methods import METHODS as SKF_METHODS

    skf = benches.add_parser(
        "skf", help="feng2019 Table 1: switching Kalman filter navigation (CF, DF) vs FilterPy's IMM and KF",
        description="Rebuilds feng2019 section 4 (200 m/s, 600 m snake from 40 s to 90 s, straight to 120 s) with "
                    "the simulator's INS and GPS models and a noisy map database, and prints RMS position and "
                    "velocity errors and time per run for SKF-CF, SKF-DF, our filter without the map, "
                    "FilterPy's IMMEstimator and KalmanFilter on the same data.")
    skf.add_argument("--runs", type=_positive_int, default=150, help="Monte Carlo runs (default 150, the paper's)")
    skf.add_argument("--seed", type=int, default=2019, help="seed of the first run (default 2019)")
    skf.add_argument("--method", action="append", choices=SKF_METHODS,
                     help=f"method to run (repeatable; default all: {', '.join(SKF_METHODS)})")
    skf.add_argument("--gps-outage", type=float, nargs=2, metavar=("START_S", "END_S"),
                     help="no GPS fix between these times (not in the paper)")
    skf.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    skf.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    skf.set_defaults(handler=_outputs_checked(commands.cmd_skf), method=None)

    imm = benches.add_parser(
        "imm", help="CV + coordinated-turn IMM vs the single-model DUIF on the street-following target",
        description="Paired runs on the same detections (three UAVs circling the street-following target in the "
                    "scenario's city, occluded by its buildings): position and velocity RMSE, RMSE after the "
                    "target's turns, NEES and time per step of the DUIF and of the IMM estimator.")
    imm.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    imm.add_argument("--runs", type=_positive_int, default=50, help="paired runs (default 50)")
    imm.add_argument("--steps", type=_positive_int, default=300, help="1 s steps per run (default 300)")
    imm.add_argument("--seed", type=int, default=3000, help="seed of the first run (default 3000)")
    imm.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    imm.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    imm.set_defaults(handler=_outputs_checked(commands.cmd_imm))

    soak = benches.add_parser(
        "soak", help="the whole ground station for a long run with random faults: nothing lost, no crash, memory",
        description="Runs a router, the daemon and simulated vehicle processes on 127.0.0.1 for a long simulated "
                    "run, killing and restarting vehicle processes, silencing MAVLink links and injecting bad "
                    "samples at random; reports the samples published vs those the daemon took in (accepted or "
                    "rejected by reason), crashes, and the daemon's memory. Exit 1 if anything was lost or crashed.")
    soak.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    soak.add_argument("--vehicles", type=_positive_int, default=10, help="simulated vehicles (default 10)")
    soak.add_argument("--processes", type=_positive_int, default=5,
                      help="vehicle processes, the vehicles shared among them (default 5)")
    soak.add_argument("--duration", type=_positive_float, default=1800.0, help="simulated seconds (default 1800)")
    soak.add_argument("--rate", type=_positive_float, default=20.0,
                      help="simulated seconds per wall second (default 20)")
    soak.add_argument("--fault-every", type=_positive_float, default=3.0, metavar="S",
                      help="mean wall seconds between faults (default 3)")
    soak.add_argument("--planner", choices=PLANNERS, default=None, help="the daemon's planner (default the scenario's)")
    soak.add_argument("--seed", type=int, default=0, help="seed of the vehicles and of the faults (default 0)")
    soak.add_argument("--workdir", type=Path, metavar="DIR", help="where the logs go (default a temporary folder)")
    soak.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    soak.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    soak.set_defaults(handler=_outputs_checked(commands.cmd_soak))
    aps = benches.add_parser(
        "autopilots", help="the daemon's steering flown by each autopilot personality: course error, seen, RMSE",
        description="Flies the scenario in one process on paired seeds under each simulated autopilot "
                    "personality (ideal, arduplane, px4), with the daemon's own telemetry handling, steering "
                    "and MAVLink encoding, every message packed and parsed as on the wire, and prints per "
                    "personality the course error against the planned path (median and p90 after a 10 s "
                    "settle), seen by any UAV and per UAV, RMSE, their ratios to the ideal airframe and the "
                    "paired Wilcoxon p of seen-by-any against it.")
    aps.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    aps.add_argument("--runs", type=_positive_int, default=10, help="paired seeds per personality (default 10)")
    aps.add_argument("--seed", type=int, default=2012, help="seed of the first run (default 2012)")
    aps.add_argument("--duration", type=_positive_float, help="seconds of flight per run (default: the scenario's)")
    aps.add_argument("--autopilot", action="append", choices=["ideal", "arduplane", "px4"],
                     help="personality to fly (repeatable; default all three)")
    aps.add_argument("--compare-pursuit", action="store_true",
                     help="also fly every personality steered by pursuit of a point 4 s on the plan, without lead")
    aps.add_argument("--identify", action="store_true",
                     help="also print each personality's course loop identified from step responses")
    aps.add_argument("--workers", type=_positive_int, default=1, help="processes to fly the seeds in (default 1)")
    aps.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    aps.set_defaults(handler=_outputs_checked(commands.cmd_autopilots), autopilot=None)

    dem = benches.add_parser(
        "demo", help="gcs demo at its default settings against the same scenario and seeds in one process",
        description="For each seed, runs gcs demo (the daemon and sim-vehicles on loopback) and the in-process "
                    "loop of gcs bench autopilots on the same scene, and prints the means of seen-by-any, per UAV "
                    "and RMSE of both, with the demo's ratios to the in-process loop.")
    dem.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    dem.add_argument("--runs", type=_positive_int, default=5, help="seeds (default 5)")
    dem.add_argument("--seed", type=int, default=0, help="the first seed (default 0, gcs demo's)")
    dem.add_argument("--rate", type=_positive_float, help="the demo's speed-up (default: gcs demo's)")
    dem.add_argument("--duration", type=_positive_float, help="simulated seconds per run (default: the scenario's)")
    dem.add_argument("--wait-for-plans", action="store_true",
                     help="run the vehicles with sim-vehicles run --wait-for-plans (default: as gcs demo, without)")
    dem.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    dem.set_defaults(handler=_outputs_checked(commands.cmd_demo))

    mtt = benches.add_parser(
        "multitarget", help="many ground targets: our GNN and JPDA vs Stone Soup's, GOSPA, track scores, ms per scan",
        description="Street-following ground targets on the wang2012_urban city (two of them side by side for the "
                    "first part of the run), three UAVs on fixed orbits with the scenario's range/azimuth/elevation "
                    "sensor, occlusion by buildings, missed detections and clutter; every method is fed the same "
                    "scans and scored by GOSPA (c = 100 m, p = 2, alpha = 2), OSPA, track breaks, false tracks, id "
                    "swaps, missed truth-steps and milliseconds per scan, with a paired Wilcoxon test of GOSPA.")
    _many_target_scene_arguments(mtt)
    mtt.add_argument("--no-peers", action="store_true", help="run only our trackers, not Stone Soup's")
    mtt.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    mtt.set_defaults(handler=_outputs_checked(commands.cmd_multitarget))

    shr = benches.add_parser(
        "sharing", help="three UAVs shared between many ground targets: the summed objective, assignment, fixed orbits",
        description="The gcs bench multitarget scene flown closed loop: our JPDA tracker, and the team planned by the "
                    "sight objective summed over the tracks (weights growing with the time a track goes unseen, "
                    "deleted tracks searched for), by assignment of one track per UAV, or kept on fixed orbits. "
                    "Reports each target's in-field steps (mean and worst over the targets), each UAV's, GOSPA and "
                    "planning time, with paired Wilcoxon tests between the modes.")
    _many_target_scene_arguments(shr)
    shr.add_argument("--starvation", type=_positive_float, default=20.0,
                     help="seconds in which an unseen track's planning weight doubles (default 20)")
    shr.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    shr.set_defaults(handler=_outputs_checked(commands.cmd_sharing))

    scl = benches.add_parser(
        "scale", help="the many-target loop's decision time, ingest rate and memory for 1-20 targets and 3-10 UAVs",
        description="The gcs bench sharing loop (our JPDA tracker, UAVs assigned to tracks) for every pair of "
                    "target count and team size: the decision time (scan and plan) per step, the detections the "
                    "tracker fuses per second of its time, and the peak memory of a run.")
    scl.add_argument("--seed", type=int, default=0, help="seed of every run (default 0)")
    scl.add_argument("--steps", type=_positive_int, default=60, help="1 s steps per run (default 60)")
    scl.add_argument("--targets", type=_positive_int, nargs="+", metavar="N", default=[1, 5, 20],
                     help="target counts (default 1 5 20)")
    scl.add_argument("--uavs", type=_positive_int, nargs="+", metavar="V", default=[3, 10],
                     help="team sizes (default 3 10)")
    scl.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    scl.set_defaults(handler=_outputs_checked(commands.cmd_scale))

    for bench in benches.choices.values():  # errors name the benchmark: "gcs bench soak: error: ..."
        bench.set_defaults(command_prog=bench.prog)


def _many_target_scene_arguments(parser: argparse.ArgumentParser) -> None:
    """The runs and the scene of the many-target benches (gcs.bench.multitarget.BenchConfig)."""
    parser.add_argument("--runs", type=_positive_int, default=10, help="paired runs (seeds) (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first run (default 0)")
    parser.add_argument("--targets", type=_positive_int, default=5, help="ground targets (default 5)")
    parser.add_argument("--steps", type=_positive_int, default=120, help="1 s steps per run (default 120)")
    parser.add_argument("--pd", type=_probability, default=0.9, help="probability of detection in sight (default 0.9)")
    parser.add_argument("--clutter", type=_non_negative_float, default=2.0,
                        help="mean false detections per UAV and scan (default 2.0)")
