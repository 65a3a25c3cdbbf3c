"""Finding the installed console scripts, for tests that run them as processes."""

from __future__ import annotations

import shutil
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
