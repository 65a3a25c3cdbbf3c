"""The figures of one estimator over paired runs: accuracy, lost tracks, consistency and time.

Per run, over the steps with a track (the same steps for every estimator: the
track starts at the run's first range detection), with ``e_k`` the distance
from the point estimate to the car:

* RMSE ``sqrt(mean e_k^2)``; pooled over runs: the same over every step of every run;
* the error's 95th percentile and maximum (pooled);
* steps with ``e_k > 50 m`` and ``> 100 m``, and runs with any;
* NEES inside its 95% band: the share of steps whose position NEES
  ``e^T P_pp^-1 e`` (2 degrees of freedom) lies in ``[chi2_2(0.025), chi2_2(0.975)]``;
  a consistent filter scores 0.95;
* time per step (fuse plus the k+1..k+n horizon): median and the 10th-90th percentile spread, milliseconds;
* paired against the baseline: the Wilcoxon signed-rank test of the per-run RMSE (two-sided),
  and on how many seeds the estimator is the better one.

The longest unseen stretch (steps in a row that no UAV saw the car) is a
property of the run, the same for every estimator.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.stats import wilcoxon

from benchmarks import lost_track
from benchmarks.lost_track import NEES_BAND, error_figures, nees_inside
from benchmarks.roads.estimators import Trace
from benchmarks.roads.scene import Run

__all__ = ["run_figures", "summary", "paired", "longest_unseen", "NEES_BAND"]


def longest_unseen(run: Run) -> int:
    """Most consecutive steps at which no UAV saw the car."""
    return lost_track.longest_unseen(run.seen.any(axis=1))


def run_figures(run: Run, trace: Trace) -> dict:
    """Per-step errors, NEES flags and times of one run (steps with a track)."""
    tracked = np.isfinite(trace.mean[:, 0])
    error = trace.mean[tracked, :2] - run.truth_xy[tracked]
    distance = np.hypot(error[:, 0], error[:, 1])
    nees = np.einsum("ka,ka->k", error, np.linalg.solve(trace.cov[tracked, :2, :2], error[..., None])[..., 0])
    return {"errors_m": distance, "nees_inside": nees_inside(nees),
            "step_ms": 1e3 * (trace.fuse_s[tracked] + trace.horizon_s[tracked]),
            "rmse_m": float(np.sqrt(np.mean(distance**2))) if distance.size else float("nan")}


def summary(figures: Sequence[dict]) -> dict:
    """Pooled figures of one estimator over its runs (module docstring)."""
    errors = np.concatenate([f["errors_m"] for f in figures])
    times = np.concatenate([f["step_ms"] for f in figures])
    return {
        "rmse_pooled_m": float(np.sqrt(np.mean(errors**2))),
        "rmse_mean_m": float(np.mean([f["rmse_m"] for f in figures])),
        **error_figures([f["errors_m"] for f in figures]),
        "nees_inside": float(np.concatenate([f["nees_inside"] for f in figures]).mean()),
        "ms_median": float(np.median(times)),
        "ms_p10": float(np.percentile(times, 10)),
        "ms_p90": float(np.percentile(times, 90)),
    }


def paired(candidate: Sequence[dict], baseline: Sequence[dict]) -> dict:
    """Wilcoxon signed-rank test of the per-run RMSE (two-sided) and the seeds the candidate wins."""
    a = np.array([f["rmse_m"] for f in candidate])
    b = np.array([f["rmse_m"] for f in baseline])
    if np.allclose(a, b):
        return {"p": 1.0, "better": 0, "runs": len(a)}
    return {"p": float(wilcoxon(a, b).pvalue), "better": int((a < b).sum()), "runs": len(a)}
