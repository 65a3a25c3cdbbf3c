"""The layers hold, as ``lint-imports`` checks them: protocols -> core -> config -> engine -> adapters -> shells.

The contracts are pyproject.toml's ``[tool.importlinter]``; ``make test`` runs them here. A copy of
the tree with one engine module that imports the daemon, and one product test that imports a benchmark,
shows that they catch a breach.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("gcs", "protocols", "sim_vehicles", "benchmarks", "tests")
LINT_IMPORTS = "from importlinter.cli import lint_imports_command; lint_imports_command()"


def lint_imports(cwd: Path) -> subprocess.CompletedProcess:
    """``lint-imports`` on the tree at ``cwd`` (its pyproject.toml), without a cache written there."""
    return subprocess.run([sys.executable, "-c", LINT_IMPORTS, "--no-cache"], cwd=cwd, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "COLUMNS": "200"})


def test_every_import_contract_is_kept() -> None:
    result = lint_imports(ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "BROKEN" not in result.stdout and "0 broken" in result.stdout


def test_an_engine_module_that_imports_the_daemon_and_a_test_that_imports_a_benchmark_break_the_contracts(
        tmp_path: Path) -> None:
    for package in PACKAGES:
        for source in (ROOT / package).rglob("*.py"):
            target = tmp_path / source.relative_to(ROOT)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
    shutil.copyfile(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    (tmp_path / "gcs" / "engine" / "probe.py").write_text("from gcs.daemon.app import Daemon\n")
    (tmp_path / "tests" / "unit" / "probe.py").write_text("from benchmarks.urban import run_closed_loop\n")
    result = lint_imports(tmp_path)
    assert result.returncode == 1
    assert "gcs.engine.probe -> gcs.daemon.app" in result.stdout
    assert "protocols -> core -> config -> engine -> adapters -> shells BROKEN" in result.stdout
    assert "the core and the engine use no I/O library, nor the scenario files BROKEN" in result.stdout  # zenoh
    assert "tests.unit.probe -> benchmarks.urban" in result.stdout
    assert "the product's tests use no benchmark" in result.stdout and "benchmarks/tests) BROKEN" in result.stdout
