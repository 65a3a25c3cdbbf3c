"""Shared test set-up: deterministic Hypothesis, and markers by directory."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

# Explicit seeds everywhere: Hypothesis derives its examples from the test itself,
# so a red run is reproducible and CI never flakes on a fresh random draw.
settings.register_profile(
    "project", derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile("project")

_TESTS = Path(__file__).parent


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark every test with the directory it lives in: unit, integration or e2e."""
    for item in items:
        kind = Path(item.fspath).relative_to(_TESTS).parts[0]
        if kind in ("unit", "integration", "e2e"):
            item.add_marker(getattr(pytest.mark, kind))
