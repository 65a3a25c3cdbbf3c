"""``gcs-bench autopilots --sitl PATH``: the real ArduPlane (SITL) beside the ``arduplane`` personality, on the same seeds.

**Flights.** :mod:`benchmarks.sitl.flight` flies the scenario with one ArduPlane SITL per vehicle
(``takeoff = "pilot"``: airborne and at their start points before each seed's target starts), the daemon
and the payload bridge, in a private network namespace; the personality flies the same seeds in
process (:func:`benchmarks.autopilots.fly`). Both give the course following of
:mod:`benchmarks.course_following`, seen by any UAV and per UAV, and the RMSE (pooled over the scored
steps; per run for the paired test). The paired Wilcoxon p of seen-by-any and of the per-run RMSE says
whether SITL and the personality differ.

**SITL's clock.** SITL keeps up with the wall clock only while the machine has a core to spare for it;
the daemon and the bridge run on the wall clock. Each flight's SITL seconds per wall second is reported,
and a flight under :data:`KEPT_UP` is flagged.

**Identification** (``--identify --sitl PATH``): the real ArduPlane's course steps
(:mod:`benchmarks.sitl.identify`), its course loop fitted as a personality's is
(:func:`benchmarks.autopilots.fit_course_loop`), and the personality's turn efficiency fitted to them
(:func:`benchmarks.autopilots.fit_turn_efficiency`), beside the loop the daemon steers an ArduPlane with.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
from dataclasses import asdict
from pathlib import Path

import numpy as np

from benchmarks.autopilots import fit_course_loop, fit_turn_efficiency, identify
from benchmarks.autopilots_report import _fly, summarise
from benchmarks.course_following import SteeringSample, course_following
from benchmarks.sitl.namespace import run_private
from benchmarks.urban_report import paired_p
from gcs.core.steering import COURSE_LOOPS
from sim_vehicles.arduplane import TURN_EFFICIENCY

__all__ = ["KEPT_UP", "compare", "format_comparison", "format_identification", "identify_sitl", "sitl_flights"]

KEPT_UP = 0.95
"""A flight whose SITL ran at less than this many simulated seconds per wall second did not keep up."""
FLIGHT_TIMEOUT_S = 900.0
"""Wall seconds allowed per seed, on top of the flight itself (boot, take-off, flying to the start points)."""


def sitl_flights(sitl: Path, scenario: str, seeds: list[int], duration_s: float) -> list[dict]:
    """The SITL flights of ``seeds`` (one SITL session, :mod:`benchmarks.sitl.flight`): each seed's report."""
    with tempfile.TemporaryDirectory(prefix="gcs-bench-sitl-") as folder:
        out = Path(folder) / "flights.json"
        command = [sys.executable, "-m", "benchmarks.sitl.flight", "--sitl", str(sitl), "--scenario", scenario,
                   "--takeoff", "pilot", "--duration", str(duration_s), "--json", str(out),
                   "--seeds", *map(str, seeds)]
        done = run_private(command, timeout_s=len(seeds) * (duration_s + FLIGHT_TIMEOUT_S))
        if done.returncode != 0 or not out.exists():
            raise RuntimeError(f"the SITL flights failed (exit status {done.returncode}); see the log above")
        return json.loads(out.read_text())


def _sitl_summary(reports: list[dict]) -> dict:
    """The SITL flights summarised as :func:`benchmarks.autopilots_report.summarise` summarises a personality's."""
    samples = [[SteeringSample(*row) for row in report["samples"][vid]] for report in reports
               for vid in report["vehicles"]]
    rmse = [r["summary"]["rmse_m"] for r in reports]
    scored = [r["summary"]["scored_steps"] for r in reports]
    pooled = math.sqrt(sum(e * e * n for e, n in zip(rmse, scored)) / max(sum(scored), 1))
    vehicles = reports[0]["vehicles"]
    return {
        "runs": len(reports), "seeds": [r["seed"] for r in reports], "steps": reports[0]["summary"]["steps"],
        **course_following(samples, min(r["max_turn_rate_rad_s"] for r in reports)),
        "rmse_m_per_run": rmse,
        "seen_any": [r["summary"]["seen_any"] for r in reports],
        "seen_any_mean": float(np.mean([r["summary"]["seen_any"] for r in reports])),
        "seen_per_uav_mean": [float(np.mean([r["summary"]["seen_per_uav"][v] for r in reports])) for v in vehicles],
        "rmse_m": pooled,
        "clock_ratio": [None if r["clock"] is None else r["clock"]["ratio"] for r in reports],
    }


def compare(scenario: str, sitl: Path, runs: int, seed: int, duration_s: float, progress=None) -> dict:
    """The SITL flights and the personality's on seeds ``seed .. seed + runs - 1`` (module docstring)."""
    say = progress or (lambda _msg: None)
    seeds = [seed + k for k in range(runs)]
    say(f"flying ArduPlane SITL on seeds {seeds[0]}..{seeds[-1]}, {duration_s:g} s each, in real time")
    reports = sitl_flights(sitl, scenario, seeds, duration_s)
    real = _sitl_summary(reports)
    model = summarise([_fly((scenario, "arduplane", "lead", s, duration_s)) for s in seeds])
    real["p_seen_any"] = paired_p(real["seen_any"], model["seen_any"])
    real["p_rmse"] = paired_p(real["rmse_m_per_run"], model["rmse_m_per_run"])
    real["seen_any_ratio"] = real["seen_any_mean"] / model["seen_any_mean"]
    real["rmse_ratio"] = real["rmse_m"] / model["rmse_m"]
    real["kept_up"] = all(c is not None and c >= KEPT_UP for c in real["clock_ratio"])
    return {"scenario": scenario, "runs": runs, "seed": seed, "duration_s": duration_s,
            "sitl": real, "personality": model}


def format_comparison(report: dict) -> str:
    real, model = report["sitl"], report["personality"]
    lines = [f"gcs-bench autopilots --sitl: {report['scenario']}, {report['runs']} paired seeds from {report['seed']}, "
             f"{report['duration_s']:.0f} s each", "",
             "| ArduPlane | course error median / p90 / max (deg) | turn rate at the limit: achieved / planned "
             "(deg/s) | seen by any | per UAV | RMSE (m) |", "|---|---|---|---|---|---|"]
    for name, s in (("SITL", real), ("personality", model)):
        per_uav = "/".join(f"{x:.1f}" for x in s["seen_per_uav_mean"])
        lines.append(f"| {name} | {s['course_error_deg_median']:.2f} / {s['course_error_deg_p90']:.2f} / "
                     f"{s['course_error_deg_max']:.1f} | {s['turn_rate_achieved_deg_s_median']:.2f} / "
                     f"{s['turn_rate_planned_deg_s']:.2f} ({100 * s['turn_rate_ratio']:.0f}%) | "
                     f"{s['seen_any_mean']:.1f}/{s['steps']} | {per_uav} | {s['rmse_m']:.1f} |")
    clocks = [c for c in real["clock_ratio"] if c is not None]
    lines += ["", f"SITL / personality: seen by any {real['seen_any_ratio']:.3f} (paired p {real['p_seen_any']:.3g}), "
                  f"RMSE {real['rmse_ratio']:.3f} (paired p {real['p_rmse']:.3g}); course error median "
                  f"{model['course_error_deg_median'] / real['course_error_deg_median']:.2f} of SITL's, turn rate "
                  f"{model['turn_rate_ratio'] / real['turn_rate_ratio']:.2f} of SITL's",
              f"SITL's clock: {min(clocks, default=float('nan')):.3f}-{max(clocks, default=float('nan')):.3f} "
              f"simulated s per wall s ({'kept up' if real['kept_up'] else 'DID NOT KEEP UP: figures not valid'})"]
    return "\n".join(lines)


def identify_sitl(sitl: Path, airspeed_mps: float = 25.0) -> dict:
    """The real ArduPlane's course loop and the personality's turn efficiency fitted to it (module docstring)."""
    with tempfile.TemporaryDirectory(prefix="gcs-bench-identify-") as folder:
        out = Path(folder) / "steps.json"
        done = run_private([sys.executable, "-m", "benchmarks.sitl.identify", "--sitl", str(sitl), "--airspeed",
                            str(airspeed_mps), "--json", str(out)], timeout_s=FLIGHT_TIMEOUT_S)
        if done.returncode != 0 or not out.exists():
            raise RuntimeError(f"the SITL course steps failed (exit status {done.returncode}); see the log above")
        steps = json.loads(out.read_text())
    times = np.array(steps["times_s"])
    small = np.mean(steps["rates_rad_s"]["10.0"], axis=0)
    large = np.mean(steps["rates_rad_s"]["90.0"], axis=0)
    held = {float(lead): float(np.mean(rates)) for lead, rates in steps["held_rad_s"].items()}
    loop = fit_course_loop(times, small, large, airspeed_mps, bank_to_turn=True, held=held)
    efficiency = fit_turn_efficiency(loop, airspeed_mps)
    return {"sitl": asdict(loop), "turn_efficiency": efficiency,
            "personality_fitted": asdict(identify("arduplane", airspeed_mps, turn_efficiency=efficiency)),
            "personality": asdict(identify("arduplane", airspeed_mps)), "personality_turn_efficiency": TURN_EFFICIENCY,
            "steered_with": asdict(COURSE_LOOPS["arduplane"]), "bank_deg_p90": steps["bank_deg_p90"],
            "ground_speed_mps_median": steps["ground_speed_mps_median"]}


def format_identification(found: dict) -> str:
    rows = [("ArduPlane SITL, identified now", found["sitl"]),
            ("steered with (gcs/core/steering.py)", found["steered_with"]),
            (f"the personality, turn efficiency {found['personality_turn_efficiency']:.2f}", found["personality"]),
            (f"the personality, turn efficiency {found['turn_efficiency']:.3f} (fitted now)",
             found["personality_fitted"])]
    lines = ["| course loop | K (1/s) | tau (s) | largest turn rate (deg/s) |", "|---|---|---|---|"]
    lines += [f"| {name} | {loop['gain_per_s']:.3f} | {loop['lag_s']:.3f} | "
              f"{math.degrees(loop['max_turn_rate_rad_s']):.2f} |" for name, loop in rows]
    lines += ["", f"SITL bank p90 {found['bank_deg_p90']:.1f} deg, ground speed {found['ground_speed_mps_median']:.1f} m/s; "
                  "the personality's roll lag is the scenario airframe's"]
    return "\n".join(lines)
