"""The installed console scripts start as processes and list their subcommands."""

from __future__ import annotations

import subprocess

import pytest

from tests.e2e.processes import script


@pytest.mark.parametrize(("name", "expected"), [("gcs", "scenario"), ("sim-vehicles", "sim-vehicles")])
def test_console_script_help(name: str, expected: str) -> None:
    done = subprocess.run([script(name), "--help"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert expected in done.stdout


def test_gcs_without_a_subcommand_is_a_usage_error() -> None:
    done = subprocess.run([script("gcs")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "COMMAND" in done.stderr
