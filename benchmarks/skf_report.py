"""``gcs-bench skf``: run every method on the snake data, print feng2019's Table 1, write JSON.

Columns as the paper's Table 1: ``R_x``, ``R_y`` (RMS position error per axis, m),
``R_vx``, ``R_vy`` (RMS velocity error, m/s) over every run and step, and the time
(mean wall-clock seconds of one 120 s run). We add the mean position NEES (2-D;
2 for a consistent filter) and the mean number of modes per step. The methods run
one after the other on each run, so machine noise hits them alike.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from benchmarks.skf import GPS, MAP_ERROR_M, generate_dataset
from benchmarks.skf_methods import METHODS, run_method
from gcs.core.geometry import wrap_angle

__all__ = ["METHODS", "PAPER", "run_benchmark", "format_report", "write_json"]

PAPER = {
    "skf_cf": {"rms_x": 25.4061, "rms_y": 28.7646, "rms_vx": 4.5170, "rms_vy": 4.5842, "seconds": 4.2639},
    "skf_df": {"rms_x": 27.7964, "rms_y": 30.8837, "rms_vx": 4.7552, "rms_vy": 4.8320, "seconds": 3.5314},
}
"""feng2019 Table 1 (its R_z, R_vz, G_x and G_v columns have no counterpart in a horizontal filter)."""


def run_benchmark(runs: int, seed: int, methods: Sequence[str] = METHODS,
                  gps_outage_s: tuple[float, float] | None = None,
                  progress: Callable[[str], None] | None = None) -> dict:
    """Every method on ``runs`` Monte Carlo runs of the same data; the report as a dict."""
    say = progress or (lambda _msg: None)
    data = generate_dataset(runs, seed, gps_outage_s=gps_outage_s)
    truth = data.truth[1:]
    errors = {m: np.zeros((runs, data.steps, 6)) for m in methods}
    nees = {m: np.zeros((runs, data.steps)) for m in methods}
    seconds = {m: np.zeros(runs) for m in methods}
    for r in range(runs):
        for m in methods:
            out = run_method(data, r, m)
            e = out.means - truth
            e[:, 2] = wrap_angle(e[:, 2])
            errors[m][r] = e
            nees[m][r] = np.einsum("ki,ki->k", e[:, :2], np.linalg.solve(out.covs[:, :2, :2], e[:, :2, None])[..., 0])
            seconds[m][r] = out.seconds
        if (r + 1) % 10 == 0 or r + 1 == runs:
            say(f"run {r + 1}/{runs}")
    methods_report = {}
    for m in methods:
        rms = np.sqrt(np.mean(errors[m] ** 2, axis=(0, 1)))
        methods_report[m] = {
            "rms_x": float(rms[0]), "rms_y": float(rms[1]), "rms_vx": float(rms[3]), "rms_vy": float(rms[4]),
            "rms_position": float(np.hypot(rms[0], rms[1])), "rms_heading_rad": float(rms[2]),
            "nees_position": float(nees[m].mean()), "seconds": float(seconds[m].mean()),
            "seconds_median": float(np.median(seconds[m])),
        }
    return {
        "runs": runs, "seed": seed, "steps": data.steps,
        "gps_std_m": GPS.horizontal_std_m, "map_error_m": MAP_ERROR_M,
        "gps_outage_s": list(gps_outage_s) if gps_outage_s else None,
        "methods": methods_report, "paper": PAPER,
    }


def format_report(report: dict) -> str:
    """Table 1 as text, with the paper's rows beside ours."""
    outage = report["gps_outage_s"]
    lines = [f"skf benchmark (feng2019 Table 1): {report['runs']} Monte Carlo runs of {report['steps']} s from seed "
             f"{report['seed']}; GPS {report['gps_std_m']:g} m per axis, map points {report['map_error_m']:g} m"
             + (f"; no GPS from {outage[0]:g} s to {outage[1]:g} s" if outage else ""),
             f"{'method':<15}{'R_x m':>9}{'R_y m':>9}{'R_vx m/s':>10}{'R_vy m/s':>10}{'NEES(2)':>9}{'s/run':>9}"]
    for name, m in report["methods"].items():
        lines.append(f"{name:<15}{m['rms_x']:>9.2f}{m['rms_y']:>9.2f}{m['rms_vx']:>10.2f}{m['rms_vy']:>10.2f}"
                     f"{m['nees_position']:>9.2f}{m['seconds']:>9.3f}")
    for name, m in report["paper"].items():
        lines.append(f"{'paper ' + name:<15}{m['rms_x']:>9.2f}{m['rms_y']:>9.2f}{m['rms_vx']:>10.2f}{m['rms_vy']:>10.2f}"
                     f"{'':>9}{m['seconds']:>9.3f}")
    ours = report["methods"]
    if "skf_cf" in ours and "filterpy_kf" in ours:
        lines.append(f"time: skf_cf / filterpy_kf = {ours['skf_cf']['seconds'] / ours['filterpy_kf']['seconds']:.0f}x "
                     "(the paper's times are another machine's MATLAB)")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    """JSON with ``methods.<name>.{rms_x, rms_y, rms_vx, rms_vy, seconds}`` (and more)."""
    path.write_text(json.dumps(report, indent=2) + "\n")
