"""The installed console scripts start as processes and list their subcommands."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest


def _script(name: str) -> str:
    beside = Path(sys.executable).parent / name
    found = str(beside) if beside.exists() else shutil.which(name)
    if found is None:
        pytest.fail(f"console script {name!r} is not installed; run `make test` (it installs the project)")
    return found


@pytest.mark.parametrize(("script", "expected"), [("gcs", "scenario"), ("sim-vehicles", "sim-vehicles")])
def test_console_script_help(script: str, expected: str) -> None:
    done = subprocess.run([_script(script), "--help"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert expected in done.stdout


def test_gcs_without_a_subcommand_is_a_usage_error() -> None:
    done = subprocess.run([_script("gcs")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "COMMAND" in done.stderr
