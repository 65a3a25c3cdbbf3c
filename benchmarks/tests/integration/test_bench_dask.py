"""Paired runs on a Dask cluster (a LocalCluster on 127.0.0.1) give the records run here gives."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import distributed  # the cluster extra, which make installs

from benchmarks.urban_runs import RunJob, run_jobs

pytestmark = pytest.mark.integration


@pytest.fixture()
def cluster():
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, host="127.0.0.1",
                                  protocol="tcp", dashboard_address=None) as local:
        assert local.scheduler_address.startswith("tcp://127.0.0.1:")
        yield local


def test_records_from_the_cluster_equal_those_run_here(cluster) -> None:
    jobs = [RunJob("nofly_city", planner, seed, duration_s=12.0, timed=False)
            for seed in (4, 5) for planner in ("sight", "orbit")]
    remote = run_jobs(jobs, dask=cluster.scheduler_address)
    local = run_jobs(jobs)
    for a, b in zip(remote, local):
        assert (a.planner, a.seed) == (b.planner, b.seed)
        np.testing.assert_array_equal(a.vehicle_xy, b.vehicle_xy)
        np.testing.assert_array_equal(a.seen, b.seen)
        np.testing.assert_array_equal(a.errors_m, b.errors_m)


def test_bench_urban_on_the_cluster_reports_what_two_workers_report(cluster, tmp_path: Path) -> None:
    def bench(name: str, *extra: str) -> dict:
        out = tmp_path / f"{name}.json"
        done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "urban", "--scenario", "nofly_city", "--runs", "2",
                               "--duration", "10", "--planners", "sight", "orbit", "--no-scaling", "--seed", "8",
                               "--json", str(out), *extra], capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        return json.loads(out.read_text())

    on_cluster = bench("cluster", "--dask", cluster.scheduler_address)
    pooled = bench("pooled", "--workers", "2")
    for name in ("sight", "orbit"):
        for key in ("seen_any", "seen_per_uav_mean", "rmse_m", "violations", "lost_runs"):
            assert on_cluster["planners"][name][key] == pooled["planners"][name][key], (name, key)
