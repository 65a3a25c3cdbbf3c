"""Shared test set-up of the product's tests (tests/) and the benchmarks' (benchmarks/tests/): deterministic
Hypothesis, and markers by directory."""

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

KINDS = ("unit", "integration", "e2e")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark every test with the directory it lives in under a ``tests`` folder: unit, integration or e2e."""
    for item in items:
        parts = Path(item.fspath).parts
        kinds = [kind for folder, kind in zip(parts, parts[1:]) if folder == "tests" and kind in KINDS]
        if kinds:
            item.add_marker(getattr(pytest.mark, kinds[-1]))
