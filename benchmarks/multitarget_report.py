"""``gcs-bench multitarget``: paired runs over seeds, the per-method table, the paired test, the JSON.

Per method and over all runs: the mean over runs of each run's mean GOSPA and OSPA
(after the warm-up) and of its track breaks, false tracks, id swaps and missed
truth-steps; ``ms_per_scan`` is the median over every scan of every run, with its
interquartile range (``ms_per_scan_p25``, ``ms_per_scan_p75``). GOSPA is compared across
seeds by the paired Wilcoxon signed-rank test (``scipy.stats.wilcoxon``) of per-seed
GOSPA, ours (Gaussian and on the roads) against Stone Soup's method of the same
association, and so are the per-seed id swaps. The methods run alternated scan by scan
(:mod:`benchmarks.multitarget_methods`), so each scan's times are paired: the speed ratio
of Stone Soup's JPDA over ours (``jpda`` and ``jpda_roads``) is the median of the per-scan
ratios, with their interquartile range.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from benchmarks import multitarget as mt
from benchmarks.multitarget_methods import run_methods

__all__ = ["FIGURES", "run_benchmark", "format_report", "write_json"]

FIGURES = ("gospa", "ospa", "track_breaks", "false_tracks", "id_swaps", "missed", "ms_per_scan")
PAIRS = (("gnn", "stonesoup_gnn"), ("jpda", "stonesoup_jpda"), ("gnn_roads", "stonesoup_gnn"),
         ("jpda_roads", "stonesoup_jpda"))


def run_benchmark(config: mt.BenchConfig, runs: int, seed: int, peers: bool,
                  progress: Callable[[str], None] = lambda _: None) -> dict:
    """Run every method on the seeds ``seed .. seed + runs - 1`` and summarise; the report as a dict."""
    from gcs.config.world import build_world
    from gcs.engine.tracker_factory import filter_sensor_models
    from gcs.scenarios import load_scenario

    scenario = load_scenario("wang2012_urban")
    world = build_world(scenario)
    sensor = filter_sensor_models(scenario)[0]
    altitudes = [v.altitude_m for v in scenario.vehicles][:len(mt.ORBITS)]
    max_range = float(scenario.sensor.max_range_m)
    note = None
    methods = list(mt.OURS)
    if peers:
        try:
            import benchmarks.stonesoup_peer  # noqa: F401
            methods += list(mt.PEERS)
        except ImportError as error:
            note = f"Stone Soup peers not run: {error}"
            progress(note)
    per_seed: list[dict] = []
    seconds: dict[str, list[float]] = {m: [] for m in methods}
    densities = []
    for run in range(runs):
        rng = np.random.default_rng(seed + run)
        scene = mt.make_scene(world, altitudes, config, rng)
        scans = mt.make_scans(world, scene, sensor, max_range, config, rng)
        density = mt.clutter_density(world, scene, sensor, max_range, config.clutter)
        densities.append(density)
        results = run_methods(scans, scene, config, methods, world, scenario, sensor.target_height_m, density)
        scores = {m: mt.score_run(r, scene.truth_xy, config.warm_up) for m, r in results.items()}
        for m, r in results.items():
            seconds[m].extend(r.seconds)
        per_seed.append({"seed": seed + run, "methods": scores})
        progress(f"seed {seed + run}: " + ", ".join(f"{m} GOSPA {s['gospa']:.1f} m" for m, s in scores.items()))
    summary = {}
    for m in methods:
        row = {f: float(np.mean([s["methods"][m][f] for s in per_seed])) for f in FIGURES if f != "ms_per_scan"}
        row["ms_per_scan"], row["ms_per_scan_p25"], row["ms_per_scan_p75"] = spread(1e3 * np.array(seconds[m]))
        summary[m] = row
    return {"methods": summary, "config": {**vars_of(config), "runs": runs, "seed": seed, "peers": peers},
            "gospa_cutoff_m": mt.CUTOFF_M, "gospa_p": mt.ORDER_P, "gospa_alpha": 2.0,
            "empty_gospa_m": mt.CUTOFF_M * float(np.sqrt(config.targets / 2.0)),
            "occlusion": "buildings (line of sight)", "paired_tests": paired_tests(per_seed, methods),
            "clutter_density_per_m_rad2": [float(d) for d in densities],
            "speed_ratio_stonesoup_jpda_over_jpda": speed_ratio(seconds, "jpda"),
            "speed_ratio_stonesoup_jpda_over_jpda_roads": speed_ratio(seconds, "jpda_roads"), "note": note,
            "per_seed": per_seed}


def vars_of(config: mt.BenchConfig) -> dict:
    return {"targets": config.targets, "steps": config.steps, "pd": config.pd, "clutter": config.clutter,
            "pair_offset_m": config.pair_offset_m, "joint_steps": config.joint_steps, "warm_up": config.warm_up}


def paired_tests(per_seed: Sequence[dict], methods: Sequence[str]) -> dict:
    """Wilcoxon p-value of per-seed GOSPA, ours vs the peer of the same association (None if not computable);
    and of per-seed id swaps (``swaps_*``)."""
    out = {}
    for ours, peer in PAIRS:
        if ours not in methods or peer not in methods:
            continue
        a, b = (np.array([s["methods"][m]["gospa"] for s in per_seed]) for m in (ours, peer))
        swaps_a, swaps_b = (np.array([s["methods"][m]["id_swaps"] for s in per_seed]) for m in (ours, peer))
        out[f"{ours}_vs_{peer}"] = {"p_value": _wilcoxon(a, b), "mean_difference_m": float(np.mean(a - b)),
                                    "seeds_ours_better": int(np.sum(a < b)), "seeds": len(a),
                                    "swaps_p_value": _wilcoxon(swaps_a, swaps_b),
                                    "swaps_mean_difference": float(np.mean(swaps_a - swaps_b)),
                                    "seeds_ours_fewer_swaps": int(np.sum(swaps_a < swaps_b))}
    return out


def _wilcoxon(a: np.ndarray, b: np.ndarray) -> float | None:
    """The paired Wilcoxon signed-rank p-value of ``a`` against ``b``; None when every difference is zero or there
    are too few seeds."""
    from scipy.stats import wilcoxon

    try:
        return float(wilcoxon(a, b).pvalue)
    except ValueError:
        return None


def spread(values: np.ndarray) -> tuple[float, float, float]:
    """Median, 25th and 75th percentiles."""
    p25, median, p75 = np.percentile(values, [25.0, 50.0, 75.0])
    return float(median), float(p25), float(p75)


def speed_ratio(seconds: dict[str, list[float]], ours: str) -> dict[str, float] | None:
    """Stone Soup's JPDA's time over ``ours``' scan by scan (the same scans, alternated): median and IQR."""
    if "stonesoup_jpda" not in seconds or ours not in seconds:
        return None
    median, p25, p75 = spread(np.array(seconds["stonesoup_jpda"]) / np.array(seconds[ours]))
    return {"median": median, "p25": p25, "p75": p75}


def format_report(report: dict) -> str:
    cfg = report["config"]
    pair = (f" (a side-by-side pair {cfg['pair_offset_m']:g} m apart for {cfg['joint_steps']} steps)"
            if cfg["targets"] >= 2 else "")
    lines = [f"gcs-bench multitarget: {cfg['runs']} runs from seed {cfg['seed']}, {cfg['targets']} targets{pair}, "
             f"{cfg['steps']} steps of 1 s, Pd {cfg['pd']:g}, clutter {cfg['clutter']:g}/UAV/scan, 3 UAVs, "
             f"occlusion by buildings",
             f"GOSPA and OSPA: c = {report['gospa_cutoff_m']:g} m, p = 2, alpha = 2, mean over steps after "
             f"{cfg['warm_up']} s (no tracks at all: {report['empty_gospa_m']:.1f} m); counts: mean per run",
             "",
             f"{'method':<16}{'GOSPA m':>9}{'OSPA m':>9}{'breaks':>8}{'false':>7}{'swaps':>7}{'missed':>8}"
             f"{'ms/scan':>10}{'IQR':>18}"]
    for name, row in report["methods"].items():
        lines.append(f"{name:<16}{row['gospa']:>9.1f}{row['ospa']:>9.1f}{row['track_breaks']:>8.1f}"
                     f"{row['false_tracks']:>7.1f}{row['id_swaps']:>7.1f}{row['missed']:>8.1f}"
                     f"{row['ms_per_scan']:>10.2f}{_iqr(row['ms_per_scan_p25'], row['ms_per_scan_p75']):>18}")
    for name, test in report["paired_tests"].items():
        p = "n/a" if test["p_value"] is None else f"{test['p_value']:.3g}"
        swaps_p = "n/a" if test.get("swaps_p_value") is None else f"{test['swaps_p_value']:.3g}"
        lines.append(f"GOSPA {name}: mean difference {test['mean_difference_m']:+.1f} m, ours lower on "
                     f"{test['seeds_ours_better']}/{test['seeds']} seeds, Wilcoxon p = {p}; id swaps "
                     f"{test.get('swaps_mean_difference', 0.0):+.1f} a run, fewer on "
                     f"{test.get('seeds_ours_fewer_swaps', 0)}/{test['seeds']} seeds, Wilcoxon p = {swaps_p}")
    for ours in ("jpda", "jpda_roads"):
        ratio = report.get(f"speed_ratio_stonesoup_jpda_over_{ours}")
        if ratio is not None:
            lines.append(f"speed, scan by scan: stonesoup_jpda / {ours} = {ratio['median']:.1f}x median "
                         f"(IQR {_iqr(ratio['p25'], ratio['p75'], '.1f')})")
    if report["note"]:
        lines.append(report["note"])
    return "\n".join(lines)


def _iqr(low: float, high: float, spec: str = ".2f") -> str:
    return f"{low:{spec}}-{high:{spec}}"


def write_json(report: dict, path: Path) -> None:
    path.write_text(json.dumps(report, indent=2) + "\n")
