"""The installed console scripts start as processes and list their subcommands."""

from __future__ import annotations

import subprocess

import pytest

from gcs.cli_errors import BROKEN_PIPE_STATUS
from tests.e2e.processes import output_read_by_nobody, script


@pytest.mark.parametrize(("name", "expected"), [("gcs", "scenario"), ("sim-vehicles", "sim-vehicles")])
def test_console_script_help(name: str, expected: str) -> None:
    done = subprocess.run([script(name), "--help"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert expected in done.stdout


def test_gcs_without_a_subcommand_is_a_usage_error() -> None:
    done = subprocess.run([script("gcs")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "COMMAND" in done.stderr


@pytest.mark.parametrize(("argv", "status"), [
    (["gcs", "scenario", "show", "wang2012_urban"], BROKEN_PIPE_STATUS), (["gcs", "scenario", "list"], BROKEN_PIPE_STATUS),
    (["gcs", "--help"], 0), (["sim-vehicles", "--help"], 0),  # argparse's help ignores a write that fails
], ids=lambda value: " ".join(value) if isinstance(value, list) else str(value))
def test_output_to_a_reader_that_went_away_ends_quietly(argv: list[str], status: int) -> None:
    # `gcs scenario show wang2012_urban | head`: status 141, as for a program SIGPIPE ends, and no traceback
    assert output_read_by_nobody([script(argv[0]), *argv[1:]]) == (status, "")
