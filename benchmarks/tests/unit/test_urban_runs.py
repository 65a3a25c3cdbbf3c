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



def test_a_job_runs_the_estimator_it_names() -> None:
    """fast_target's car drives a street grid, so its scenario's ``auto`` is the road tracker; a job naming the
    DUIF runs the DUIF, and a job naming ``road`` gives the default's records bit for bit."""
    default, road, duif = run_jobs([RunJob("fast_target", "orbit", 3, duration_s=12.0, timed=False, estimator=kind)
                                    for kind in (None, "road", "duif")])
    np.testing.assert_array_equal(default.errors_m, road.errors_m)
    # the truth and the orbits are the same whatever the estimator: only the tracks differ
    np.testing.assert_array_equal(default.target_xy, duif.target_xy)
    assert np.any(default.errors_m != duif.errors_m)
