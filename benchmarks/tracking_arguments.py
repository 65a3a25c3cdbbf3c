"""``gcs-bench``'s parsers of the papers' experiments and the trackers: estimation, urban, aoa, skf, imm,
multitarget, sharing, scale and roads (:mod:`benchmarks.commands` runs them)."""

from __future__ import annotations

import argparse
from pathlib import Path

from benchmarks import PLANNERS, SEARCH_VARIANTS, commands
from benchmarks.arguments import (PLOTS_HELP, finish, non_negative_float, outputs_checked, positive_float,
                                  positive_int, probability)

__all__ = ["add_estimation", "add_urban", "add_aoa", "add_skf", "add_imm", "add_multitarget", "add_sharing",
           "add_scale", "add_roads", "add_federation"]

def add_estimation(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench estimation``."""
    est = sub.add_parser(
        "estimation",
        help="DUIF vs FilterPy's UKF: RMSE, RMSE/sqrt(PCRLB), NEES, microseconds per step",
        description="Feeds the same generated data (wang2012's sensor set-up, vehicles loitering around "
                    "the target) to our DUIF and to FilterPy's UnscentedKalmanFilter with every vehicle "
                    "stacked, and reports accuracy against the PCRLB and speed (the methods alternated step "
                    "by step; median and interquartile range), plus a table for 1, 3, 10 and 30 vehicles and "
                    "a part with 20 targets seen by the same 3 vehicles.",
    )
    est.add_argument("--runs", type=positive_int, default=100, help="Monte Carlo runs with 3 vehicles (default 100)")
    est.add_argument("--steps", type=positive_int, default=100, help="1 s steps per run (default 100)")
    est.add_argument("--table-runs", type=positive_int, default=5, help="runs per row of the vehicle-count table (default 5)")
    est.add_argument("--scenes", type=positive_int, default=5,
                     help="scenes of 20 targets seen by the same 3 vehicles (default 5)")
    est.add_argument("--seed", type=int, default=2012, help="seed of the generated data (default 2012)")
    est.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    est.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    est.set_defaults(handler=outputs_checked(commands.cmd_estimation))
    finish(est)


def add_urban(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench urban``."""
    from benchmarks.urban_scene import NAVIGATIONS

    urb = sub.add_parser(
        "urban",
        help="closed loop in the city: observations, RMSE, airspace violations and decision time per planner",
        description="Runs the closed loop through the engine (truth target, occluded sensing, the scenario's "
                    "target estimator, k+n prediction, planning, UAVs flying the first command) on paired seeds "
                    "for each planner and prints, per planner, the steps seen by any UAV and per UAV, RMSE, "
                    "how the track was lost (error p95 and max, runs and steps over 50 and 100 m, longest unseen "
                    "stretch, NEES inside its 95%% band), airspace violations, decision times and paired "
                    "Wilcoxon p-values against the orbit and k+0; then the decision time of the sight planner "
                    "and of wang2012's GA for 3, 6, 10 and 20 UAVs. Shipped scenarios: gcs scenario list.",
    )
    urb.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    urb.add_argument("--runs", type=positive_int, default=10, help="paired runs per planner (default 10)")
    urb.add_argument("--seed", type=int, default=2012, help="seed of the first run (default 2012)")
    urb.add_argument("--planners", nargs="+", action="extend", choices=PLANNERS + SEARCH_VARIANTS, metavar="PLANNER",
                     help=f"planners to run (default: {', '.join(PLANNERS)}; also {', '.join(SEARCH_VARIANTS)}, "
                          "the sight objective searched otherwise)")
    urb.add_argument("--planner", action="append", choices=PLANNERS + SEARCH_VARIANTS, dest="planners",
                     help=argparse.SUPPRESS)
    urb.add_argument("--duration", type=positive_float, help="seconds of simulation per run (default: the scenario's)")
    urb.add_argument("--motion", choices=["white_noise_acceleration", "streets"],
                     help="target motion (default: the scenario's)")
    urb.add_argument("--estimator", choices=["auto", "road", "duif", "imm", "vgukf"],
                     help="target estimator in place of the scenario's [estimator] kind (auto: the road tracker "
                          "where the world has roads, else the DUIF)")
    urb.add_argument("--workers", type=positive_int, default=1,
                     help="run the seeds in this many processes (default 1); results are the same whatever the number")
    urb.add_argument("--dask", metavar="ADDRESS",
                     help="run the seeds on the Dask cluster whose scheduler is at ADDRESS, e.g. tcp://127.0.0.1:8786 "
                          "(needs the cluster extra: pip install .[cluster])")
    urb.add_argument("--no-scaling", action="store_true", help="skip the 3/6/10/20-UAV timing table")
    urb.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    urb.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    urb.add_argument("--gps-denied", action="store_true",
                     help="GPS-denied zones (the scenario's, else a 1.5 km square about the target's start): target "
                          "RMSE with the vehicles' own navigation (perfect, reported, the engine's SKF); planner "
                          "default ga_k5")
    urb.add_argument("--navigation", action="append", choices=NAVIGATIONS,
                     help="with --gps-denied: navigation to run (repeatable; default all)")
    urb.set_defaults(handler=outputs_checked(commands.cmd_urban), planners=None, navigation=None)
    finish(urb)


def add_aoa(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench aoa``."""
    aoa = sub.add_parser(
        "aoa", help="zuo2021 bearing-only tracking: estimators, GCRLB-LM vs CRLB vs straight-line planners",
        description="Reproduces zuo2021 section 5 over paired runs: estimator MSE on straight flight (Fig. 2), "
                    "the closed loop with the GCRLB-LM, Dogancay CRLB-LM and straight-line planners (Figs. 3-6), "
                    "2-6 sensors (Fig. 7) and unequal sensor accuracies 1 / 0.8 / 0.1 deg (Fig. 8).")
    aoa.add_argument("--runs", type=positive_int, default=50, help="paired Monte Carlo runs (default 50)")
    aoa.add_argument("--steps", type=positive_int, default=100, help="1 s steps per run (default 100)")
    aoa.add_argument("--seed", type=int, default=2021, help="seed of the first run (default 2021)")
    aoa.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    aoa.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    aoa.set_defaults(handler=outputs_checked(commands.cmd_aoa))
    finish(aoa)


def add_skf(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench skf``."""
    from benchmarks.skf_methods import METHODS as SKF_METHODS

    skf = sub.add_parser(
        "skf", help="feng2019 Table 1: switching Kalman filter navigation (CF, DF) vs FilterPy's IMM and KF",
        description="Rebuilds feng2019 section 4 (200 m/s, 600 m snake from 40 s to 90 s, straight to 120 s) with "
                    "the simulator's INS and GPS models and a noisy map database, and prints RMS position and "
                    "velocity errors and time per run for SKF-CF, SKF-DF, our filter without the map, "
                    "FilterPy's IMMEstimator and KalmanFilter on the same data.")
    skf.add_argument("--runs", type=positive_int, default=150, help="Monte Carlo runs (default 150, the paper's)")
    skf.add_argument("--seed", type=int, default=2019, help="seed of the first run (default 2019)")
    skf.add_argument("--method", action="append", choices=SKF_METHODS,
                     help=f"method to run (repeatable; default all: {', '.join(SKF_METHODS)})")
    skf.add_argument("--gps-outage", type=float, nargs=2, metavar=("START_S", "END_S"),
                     help="no GPS fix between these times (not in the paper)")
    skf.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    skf.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    skf.set_defaults(handler=outputs_checked(commands.cmd_skf), method=None)
    finish(skf)


def add_imm(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench imm``."""
    imm = sub.add_parser(
        "imm", help="CV + coordinated-turn IMM vs the single-model DUIF on the street-following target",
        description="Paired runs on the same detections (three UAVs circling the street-following target in the "
                    "scenario's city, occluded by its buildings): position and velocity RMSE, RMSE after the "
                    "target's turns, NEES and time per step of the DUIF and of the IMM estimator.")
    imm.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    imm.add_argument("--runs", type=positive_int, default=50, help="paired runs (default 50)")
    imm.add_argument("--steps", type=positive_int, default=300, help="1 s steps per run (default 300)")
    imm.add_argument("--seed", type=int, default=3000, help="seed of the first run (default 3000)")
    imm.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    imm.add_argument("--plots", type=Path, metavar="DIR", help=PLOTS_HELP)
    imm.set_defaults(handler=outputs_checked(commands.cmd_imm))
    finish(imm)


def add_multitarget(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench multitarget``."""
    mtt = sub.add_parser(
        "multitarget",
        help="many ground targets: our GNN and JPDA (Gaussian and on the roads) vs Stone Soup's, GOSPA, track "
             "scores, ms per scan",
        description="Street-following ground targets on the wang2012_urban city (two of them side by side for the "
                    "first part of the run), three UAVs on fixed orbits with the scenario's range/azimuth/elevation "
                    "sensor, occlusion by buildings, missed detections and clutter; every method is fed the same "
                    "scans and scored by GOSPA (c = 100 m, p = 2, alpha = 2), OSPA, track breaks, false tracks, id "
                    "swaps, missed truth-steps and milliseconds per scan, with a paired Wilcoxon test of GOSPA.")
    _many_target_scene_arguments(mtt)
    mtt.add_argument("--no-peers", action="store_true", help="run only our trackers, not Stone Soup's")
    mtt.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    mtt.set_defaults(handler=outputs_checked(commands.cmd_multitarget))
    finish(mtt)


def add_sharing(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench sharing``."""
    shr = sub.add_parser(
        "sharing", help="three UAVs shared between many ground targets: the summed objective, assignment, fixed orbits",
        description="The gcs-bench multitarget scene flown closed loop: our JPDA tracker, and the team planned by the "
                    "sight objective summed over the tracks (weights growing with the time a track goes unseen, "
                    "deleted tracks searched for), by assignment of one track per UAV, or kept on fixed orbits. "
                    "Reports each target's in-field steps (mean and worst over the targets), each UAV's, GOSPA and "
                    "planning time, with paired Wilcoxon tests between the modes.")
    _many_target_scene_arguments(shr)
    shr.add_argument("--starvation", type=positive_float, default=20.0,
                     help="seconds in which an unseen track's planning weight doubles (default 20)")
    shr.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    shr.set_defaults(handler=outputs_checked(commands.cmd_sharing))
    finish(shr)


def add_scale(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench scale``."""
    scl = sub.add_parser(
        "scale", help="the many-target loop's decision time, ingest rate and memory for 1-20 targets and 3-10 UAVs",
        description="The gcs-bench sharing loop (our JPDA tracker, UAVs assigned to tracks) for every pair of "
                    "target count and team size: the decision time (scan and plan) per step, the detections the "
                    "tracker fuses per second of its time, and the peak memory of a run.")
    scl.add_argument("--seed", type=int, default=0, help="seed of every run (default 0)")
    scl.add_argument("--steps", type=positive_int, default=60, help="1 s steps per run (default 60)")
    scl.add_argument("--targets", type=positive_int, nargs="+", metavar="N", default=[1, 5, 20],
                     help="target counts (default 1 5 20)")
    scl.add_argument("--uavs", type=positive_int, nargs="+", metavar="V", default=[3, 10],
                     help="team sizes (default 3 10)")
    scl.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    scl.set_defaults(handler=outputs_checked(commands.cmd_scale))
    finish(scl)


def add_roads(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench roads`` (:mod:`benchmarks.roads`)."""
    from benchmarks.roads.command import add_arguments, check, run

    roads = sub.add_parser(
        "roads", help="the road trackers against the scenario's estimator, open loop, paired seeds",
        description="Runs every road-tracker estimator and the scenario's own on the same car paths and detections "
                    "(three UAVs on fixed orbits) and prints a Markdown table per scenario: RMSE, lost-track "
                    "figures, NEES and time per step, with paired Wilcoxon tests.")
    add_arguments(roads)
    roads.set_defaults(handler=run)
    finish(roads)
    roads.set_defaults(check=check)  # its own options: no --json, --plots or --scenario


def _member_and_step(text: str) -> tuple[int, int]:
    """``--kill M,K``: member index and decision step."""
    parts = text.split(",")
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise argparse.ArgumentTypeError(f"expected MEMBER,STEP (two non-negative integers, e.g. 1,90), got {text!r}")
    return int(parts[0]), int(parts[1])


def add_federation(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs-bench federation``."""
    fed = sub.add_parser(
        "federation", help="several daemons with their teams, sharing tracks, against one central daemon",
        description="The city cut in one strip per member; each member's engine flies its team and publishes its "
                    "tracks to the others, which fuse them by global id (covariance intersection). Against one "
                    "engine flying every UAV on the same paired seeds: GOSPA, id changes per target, the steps "
                    "with NEES inside its 95%% band, hand-over and take-up times, bytes per second per member and "
                    "the decision time. With --processes: the members as real daemons (gcs run), each with its "
                    "simulated team (sim-vehicles run), separate processes over a Zenoh router on 127.0.0.1, in real "
                    "time, on multitarget_urban's cars and sensor (--targets, --pd, --clutter and --runs do not "
                    "apply; no central daemon): each daemon's decision time per step, the steps over the step, the "
                    "bytes per second on its federation key and the members it sees.")
    _many_target_scene_arguments(fed)
    fed.set_defaults(targets=6, steps=None)
    next(a for a in fed._actions if a.dest == "steps").help = "1 s steps per run (default 180; 120 with --processes)"
    fed.add_argument("--members", type=positive_int, default=3, help="daemons (default 3)")
    fed.add_argument("--uavs-per-member", type=positive_int, default=3, help="UAVs per daemon (default 3)")
    fed.add_argument("--fusion", choices=("ci", "independent"), default="ci",
                     help="how members' tracks of one target are fused (default ci: covariance intersection)")
    fed.add_argument("--kill", type=_member_and_step, metavar="MEMBER,STEP",
                     help="member (0-based) that dies at this decision step")
    fed.add_argument("--range", type=positive_float, default=1000.0, dest="range_m",
                     help="the UAVs' sensor range, metres (default 1000: a team sees its strip, not the city)")
    fed.add_argument("--no-central", action="store_true", help="fly the federation only")
    fed.add_argument("--processes", action="store_true",
                     help="run the members as gcs run processes with sim-vehicles teams over a Zenoh router "
                          "(implies --no-central)")
    fed.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    fed.set_defaults(handler=outputs_checked(commands.cmd_federation))
    finish(fed)


def _many_target_scene_arguments(parser: argparse.ArgumentParser) -> None:
    """The runs and the scene of the many-target benches (benchmarks.multitarget.BenchConfig)."""
    parser.add_argument("--runs", type=positive_int, default=10, help="paired runs (seeds) (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first run (default 0)")
    parser.add_argument("--targets", type=positive_int, default=5, help="ground targets (default 5)")
    parser.add_argument("--steps", type=positive_int, default=120, help="1 s steps per run (default 120)")
    parser.add_argument("--pd", type=probability, default=0.9, help="probability of detection in sight (default 0.9)")
    parser.add_argument("--clutter", type=non_negative_float, default=2.0,
                        help="mean false detections per UAV and scan (default 2.0)")
