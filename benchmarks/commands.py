"""``gcs-bench ...``: what each benchmark command does with its parsed arguments.

Each handler runs its benchmark module, prints the tables (progress goes to
stderr) and writes ``--json``; :mod:`benchmarks.cli` registers them and checks the
outputs before they run.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

from benchmarks import PLANNERS
from gcs.cli_errors import UsageError


def progress(message: str) -> None:
    print(f"  ... {message}", file=sys.stderr, flush=True)


def wrote(paths) -> None:
    for path in paths:
        print(f"wrote {path}")


def keep_json(write_json: Callable[[dict, Path], None], report: dict, path: Path | None) -> None:
    """``--json FILE``: the report written there, and said so; nothing without the option."""
    if path:
        write_json(report, path)
        wrote([path])


def cmd_estimation(args: argparse.Namespace) -> int:
    from benchmarks import estimation

    report = estimation.run_benchmark(
        runs=args.runs, seed=args.seed, steps=args.steps, table_runs=args.table_runs, scenes=args.scenes,
        progress=progress
    )
    print(estimation.format_report(report))
    keep_json(estimation.write_json, report, args.json)
    if args.plots:
        wrote(estimation.write_plots(report, args.plots))
    return 0


def cmd_urban(args: argparse.Namespace) -> int:
    from benchmarks import urban_report
    from benchmarks.urban_runs import DaskUnavailable
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    scenario = load_scenario(args.scenario)
    world = build_world(scenario)
    if args.gps_denied:
        from benchmarks.urban_runs import with_estimator

        return urban_gps_denied(args, with_estimator(scenario, args.estimator) if args.estimator else scenario, world)
    try:
        report, records = urban_report.run_benchmark(
            args.scenario, scenario, world, runs=args.runs, seed=args.seed, planners=args.planners or PLANNERS,
            duration_s=args.duration, motion=args.motion, scaling=() if args.no_scaling else (3, 6, 10, 20),
            workers=args.workers, dask=args.dask, progress=progress, estimator=args.estimator)
    except DaskUnavailable as error:
        print(f"gcs-bench urban: {error}", file=sys.stderr)
        return 2
    print(urban_report.format_report(report))
    keep_json(urban_report.write_json, report, args.json)
    if args.plots:
        wrote(urban_report.write_plots(report, records, world, args.plots))
    return 0


def urban_gps_denied(args: argparse.Namespace, scenario, world) -> int:
    from benchmarks import urban_nav_report

    report = urban_nav_report.run_benchmark(
        scenario, world, runs=args.runs, seed=args.seed, planners=args.planners or ("ga_k5",),
        navigations=args.navigation or urban_nav_report.NAVIGATION_MODES, duration_s=args.duration,
        motion=args.motion, progress=progress)
    print(urban_nav_report.format_report(report))
    keep_json(urban_nav_report.write_json, report, args.json)
    if args.plots:
        from benchmarks.navigation_plots import write_gps_denied_plots

        wrote(write_gps_denied_plots(report, args.plots))
    return 0


def cmd_daemon(args: argparse.Namespace) -> int:
    import cProfile

    from benchmarks import daemon
    from benchmarks.daemon_load import LOAD_NICENESS
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    scenario = load_scenario(args.scenario)
    command = (f"gcs-bench daemon --scenario {args.scenario} --vehicles {' '.join(map(str, args.vehicles))} "
               f"--seconds {args.seconds:g} --solve-steps {args.solve_steps} --navigation {args.navigation}"
               + (f" --rates {' '.join(f'{r:g}' for r in args.rates)}" if args.rates else "")
               + (f" --load-nice {args.load_niceness}" if args.load_niceness != LOAD_NICENESS else ""))
    profiler = cProfile.Profile() if args.profile else None
    report = daemon.run_benchmark(scenario, build_world(scenario), vehicle_counts=args.vehicles, seconds=args.seconds,
                                  solve_steps=args.solve_steps, command=command, progress=progress, profiler=profiler,
                                  navigation=args.navigation, rates=args.rates or (),
                                  load_niceness=args.load_niceness)
    print(daemon.format_report(report))
    keep_json(daemon.write_json, report, args.json)
    if args.plots:
        from benchmarks.daemon_plots import write_plots

        wrote(write_plots(report, args.plots))
    if profiler is not None:
        profiler.dump_stats(args.profile)
        print(f"wrote {args.profile} (python -m pstats {args.profile}; the profiler slows the daemon, so rates "
              "measured with it are lower)")
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    from benchmarks import replay
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    scenario = load_scenario(args.scenario)
    report = replay.run_benchmark(scenario, build_world(scenario), duration_s=args.duration, repeats=args.repeats,
                                  seed=args.seed, progress=progress, navigation=args.navigation)
    print(replay.format_report(report))
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
        print(f"wrote {args.json}")
    if args.plots:
        wrote(replay.write_plots(report, args.plots))
    return 0


def cmd_aoa(args: argparse.Namespace) -> int:
    from benchmarks import aoa_report

    report, records = aoa_report.run_benchmark(runs=args.runs, seed=args.seed, steps=args.steps, progress=progress)
    print(aoa_report.format_report(report))
    keep_json(aoa_report.write_json, report, args.json)
    if args.plots:
        wrote(aoa_report.write_plots(report, records, args.plots))
    return 0


def cmd_livemap(args: argparse.Namespace) -> int:
    from benchmarks import livemap
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    scenario = load_scenario(args.scenario)
    command = (f"gcs-bench livemap --vehicles {' '.join(map(str, args.vehicles))} --warm-up {args.warm_up} "
               f"--seconds {args.seconds}")
    report = livemap.run_benchmark(scenario, build_world(scenario), vehicle_counts=args.vehicles,
                                   warm_up_s=args.warm_up, measure_s=args.seconds, command=command,
                                   progress=progress)
    print(livemap.format_report(report))
    if args.json:
        args.json.write_text(json.dumps(report, indent=2) + "\n")
        print(f"wrote {args.json}")
    if args.plots:
        wrote(livemap.write_plots(report, args.plots))
    return 0


def cmd_skf(args: argparse.Namespace) -> int:
    from benchmarks import skf_report

    report = skf_report.run_benchmark(runs=args.runs, seed=args.seed, methods=args.method or skf_report.METHODS,
                                      gps_outage_s=tuple(args.gps_outage) if args.gps_outage else None,
                                      progress=progress)
    print(skf_report.format_report(report))
    keep_json(skf_report.write_json, report, args.json)
    if args.plots:
        from benchmarks.navigation_plots import write_skf_plots

        wrote(write_skf_plots(report, args.plots))
    return 0


def cmd_imm(args: argparse.Namespace) -> int:
    from benchmarks import imm
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    scenario = load_scenario(args.scenario)
    report = imm.run_benchmark(scenario, build_world(scenario), runs=args.runs, seed=args.seed, steps=args.steps,
                               progress=progress)
    print(imm.format_report(report))
    keep_json(imm.write_json, report, args.json)
    if args.plots:
        from benchmarks.navigation_plots import write_imm_plots

        wrote(write_imm_plots(report, args.plots))
    return 0


def cmd_multitarget(args: argparse.Namespace) -> int:
    from benchmarks import multitarget_report
    from benchmarks.multitarget import BenchConfig

    config = BenchConfig(targets=args.targets, steps=args.steps, pd=args.pd, clutter=args.clutter)
    report = multitarget_report.run_benchmark(config, runs=args.runs, seed=args.seed, peers=not args.no_peers,
                                              progress=progress)
    return _printed(report, multitarget_report, args.json)


def cmd_sharing(args: argparse.Namespace) -> int:
    from benchmarks import sharing_report
    from benchmarks.multitarget import BenchConfig
    from benchmarks.sharing import SharingConfig

    scene = BenchConfig(targets=args.targets, steps=args.steps, pd=args.pd, clutter=args.clutter)
    report = sharing_report.run_benchmark(SharingConfig(scene, args.starvation), runs=args.runs, seed=args.seed,
                                          progress=progress)
    return _printed(report, sharing_report, args.json)


def cmd_scale(args: argparse.Namespace) -> int:
    from benchmarks import scale
    from benchmarks.multitarget import BenchConfig

    report = scale.run_benchmark(BenchConfig(steps=args.steps), seed=args.seed, targets=args.targets, uavs=args.uavs,
                                 progress=progress)
    return _printed(report, scale, args.json)


def cmd_federation(args: argparse.Namespace) -> int:
    from benchmarks import federation_report
    from benchmarks.federation import FederationConfig
    from benchmarks.multitarget import BenchConfig

    if args.processes:
        return _federation_processes(args)
    if args.kill is not None and args.kill[0] >= args.members:
        raise UsageError(f"--kill: member {args.kill[0]} is not among the {args.members} members "
                         f"(0..{args.members - 1}); give a member below --members")
    config = FederationConfig(args.members, args.uavs_per_member,
                              BenchConfig(targets=args.targets, steps=args.steps or 180, pd=args.pd,
                                          clutter=args.clutter),
                              args.fusion, args.kill, args.range_m)
    report = federation_report.run_benchmark(config, runs=args.runs, seed=args.seed, central=not args.no_central,
                                             progress=progress)
    return _printed(report, federation_report, args.json)


def _federation_processes(args: argparse.Namespace) -> int:
    """``gcs-bench federation --processes`` (:mod:`benchmarks.federation_processes`)."""
    from benchmarks import federation_processes_report
    from benchmarks.federation_processes import ProcessesConfig, run_processes

    if args.kill is not None:
        raise UsageError("--kill: not with --processes (no member is killed there); leave one of them out")
    config = ProcessesConfig(args.members, args.uavs_per_member, args.steps or 120, args.fusion, args.range_m,
                             args.seed)
    return _printed(run_processes(config, progress=progress), federation_processes_report, args.json)


def _printed(report: dict, module, json_path) -> int:
    """Print ``module.format_report(report)``, write its JSON to ``json_path`` (a Path) if given; exit status 0."""
    print(module.format_report(report))
    keep_json(module.write_json, report, json_path)
    return 0


def cmd_autopilots(args: argparse.Namespace) -> int:
    from benchmarks import autopilots_report

    if args.sitl is not None:
        return _autopilots_sitl(args)
    report = autopilots_report.run_benchmark(
        args.scenario, args.runs, args.seed, personalities=args.autopilot or autopilots_report.PERSONALITIES,
        duration_s=args.duration, compare_pursuit=args.compare_pursuit, workers=args.workers,
        identify_loops=args.identify, progress=progress)
    print(autopilots_report.format_report(report))
    keep_json(autopilots_report.write_json, report, args.json)
    return 0


def _autopilots_sitl(args: argparse.Namespace) -> int:
    """``gcs-bench autopilots --sitl PATH`` (:mod:`benchmarks.autopilots_sitl`)."""
    from benchmarks import autopilots_sitl
    from benchmarks.sitl.arduplane import find_binary
    from benchmarks.sitl.namespace import namespace_problem
    from gcs.scenarios import load_scenario

    try:
        binary = find_binary(args.sitl)
    except ValueError as error:
        raise UsageError(f"--sitl: {error}") from None
    if (problem := namespace_problem()) is not None:
        raise UsageError(f"--sitl: SITL runs in a network namespace of its own, and {problem}")
    if args.identify:
        found = autopilots_sitl.identify_sitl(binary)
        print(autopilots_sitl.format_identification(found))
        keep_json(_write_json, found, args.json)
        return 0
    scenario = load_scenario(args.scenario)
    report = autopilots_sitl.compare(args.scenario, binary, args.runs, args.seed,
                                     args.duration or scenario.time.duration_s, progress=progress)
    print(autopilots_sitl.format_comparison(report))
    keep_json(_write_json, report, args.json)
    return 0


def _write_json(report: dict, path: Path) -> None:
    path.write_text(json.dumps(report, indent=2) + "\n")


def cmd_demo(args: argparse.Namespace) -> int:
    from benchmarks import demo_compare

    report = demo_compare.run_benchmark(args.scenario, args.runs, args.seed, rate=args.rate, duration_s=args.duration,
                                        wait_for_plans=args.wait_for_plans, progress=progress)
    print(demo_compare.format_report(report))
    keep_json(demo_compare.write_json, report, args.json)
    return 0


def cmd_soak(args: argparse.Namespace) -> int:
    from benchmarks import soak

    options = soak.SoakOptions(scenario=args.scenario, vehicles=args.vehicles, processes=args.processes,
                               duration_s=args.duration, rate=args.rate, seed=args.seed,
                               fault_every_s=args.fault_every, planner=args.planner)
    command = (f"gcs-bench soak --vehicles {args.vehicles} --processes {args.processes} --duration {args.duration:g} "
               f"--rate {args.rate:g} --fault-every {args.fault_every:g} --seed {args.seed}")
    try:
        report = soak.run_soak(options, command=command, progress=progress, workdir=args.workdir)
    except ValueError as error:  # the options describe no soak (e.g. fewer vehicles than the scenario's)
        raise UsageError(error) from None
    except RuntimeError as error:
        print(f"gcs-bench soak: error: {error}", file=sys.stderr)
        return 1
    print(soak.format_report(report))
    keep_json(soak.write_json, report, args.json)
    if args.plots:
        from benchmarks.soak_plots import write_plots

        wrote(write_plots(report, args.plots))
    return 0 if report["lost"] == 0 and report["crashes_total"] == 0 else 1
