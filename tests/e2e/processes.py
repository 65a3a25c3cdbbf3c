"""Finding the installed console scripts, and stopping them, for tests that run them as processes."""

from __future__ import annotations

import ast
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest


def script(name: str) -> str:
    """Path of an installed console script (beside this Python first); fails the test when missing."""
    beside = Path(sys.executable).parent / name
    found = str(beside) if beside.exists() else shutil.which(name)
    if found is None:
        pytest.fail(f"console script {name!r} is not installed; run `make test` (it installs the project)")
    return found


def stop(process: subprocess.Popen, timeout: float = 20.0) -> int:
    """Stop a process as a user would (SIGINT), SIGKILL it if it does not return in time; its exit status."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    return process.returncode


def output_read_by_nobody(command: list[str], timeout: float = 120.0) -> tuple[int, str]:
    """Run ``command`` with its standard output a pipe whose reader has gone (``command | head`` once head has
    exited); its exit status and what it wrote to stderr."""
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    process.stdout.close()  # before the command has written anything: every write it makes finds no reader
    try:
        _, stderr = process.communicate(timeout=timeout)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return process.returncode, stderr


HEAVY_MODULES = ("numpy", "scipy", "zenoh", "pymavlink", "matplotlib")
"""What makes a command line start slowly (a second or more); ``--help`` and ``--version`` need none of it."""


def heavy_modules_loaded(package: str, argv: list[str]) -> list[str]:
    """The :data:`HEAVY_MODULES` that ``package.cli.main`` loads for ``argv`` (a fresh interpreter; the command
    must exit 0)."""
    code = (f"import sys; sys.argv = {argv!r}\n"
            f"from {package}.cli import main\n"
            "try:\n    main()\nexcept SystemExit as stop:\n    assert stop.code == 0, stop.code\n"
            f"print(sorted(m for m in {HEAVY_MODULES!r} if m in sys.modules), file=sys.stderr)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return ast.literal_eval(done.stderr.strip().splitlines()[-1])
