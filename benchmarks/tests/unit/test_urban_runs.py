"""``gcs-bench urban``'s runs give the same records in this process and in a pool of worker processes."""

from __future__ import annotations

import numpy as np

from benchmarks.urban_runs import RunJob, run_jobs


def test_results_are_the_same_whatever_the_workers() -> None:
    jobs = [RunJob("nofly_city", planner, seed, duration_s=15.0, timed=False)
            for seed in (1, 2) for planner in ("sight", "orbit")]
    here = run_jobs(jobs, workers=1)
    pooled = run_jobs(jobs, workers=2)
    for a, b in zip(here, pooled):
        assert (a.planner, a.seed) == (b.planner, b.seed)
        np.testing.assert_array_equal(a.vehicle_xy, b.vehicle_xy)
        np.testing.assert_array_equal(a.errors_m, b.errors_m)
        np.testing.assert_array_equal(a.seen, b.seen)

