"""``gcs-bench`` as an installed console script: its listing loads no benchmark, Ctrl-C stops a benchmark and its
worker processes with ``gcs-bench urban: interrupted`` and status 130, and ``gcs bench`` points to it."""

from __future__ import annotations

import os
import signal
import subprocess

from tests.e2e.processes import heavy_modules_loaded, script
from tests.loopback import Lines


def test_help_lists_every_benchmark_and_loads_no_heavy_module() -> None:
    assert heavy_modules_loaded("benchmarks", ["gcs-bench", "--help"]) == []
    listed = subprocess.run([script("gcs-bench"), "--help"], capture_output=True, text=True, timeout=60)
    assert listed.returncode == 0, listed.stderr
    for name in ("estimation", "urban", "aoa", "multitarget", "sharing", "autopilots", "roads", "soak"):
        assert name in listed.stdout


def test_gcs_bench_says_in_one_line_that_the_benchmarks_are_gcs_bench() -> None:
    done = subprocess.run([script("gcs"), "bench", "urban", "--runs", "2"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["gcs: error: the benchmarks are a command of their own: gcs-bench "
                                                "urban --runs 2"]
    listing = subprocess.run([script("gcs"), "--help"], capture_output=True, text=True, timeout=60).stdout
    assert "bench" not in listing


def test_ctrl_c_stops_a_benchmark_and_its_workers_saying_interrupted_with_status_130() -> None:
    argv = ["urban", "--runs", "20", "--duration", "60", "--workers", "2", "--planners", "sight", "orbit",
            "--no-scaling"]
    # as from a terminal: Ctrl-C at its default even where this test runs with SIGINT ignored (a background job)
    process = subprocess.Popen([script("gcs-bench"), *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, start_new_session=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        lines = Lines(process.stderr)
        lines.wait_for(r"seed \d+ \w+: seen by any", timeout_s=300)
        os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole foreground group
        process.wait(timeout=60)
        stderr = lines.rest()
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 130, stderr[-3000:]
    assert stderr.rstrip().endswith("gcs-bench urban: interrupted") and "Traceback" not in stderr, stderr[-3000:]
