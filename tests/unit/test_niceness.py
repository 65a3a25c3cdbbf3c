"""The one niceness range and check shared by the planner process, the benchmark's load and their options."""

from __future__ import annotations

import argparse
import os

import pytest

from gcs.daemon.niceness import MAX_NICENESS, check_niceness, lower_priority, niceness_argument


@pytest.mark.parametrize("value", [0, 5, MAX_NICENESS])
def test_a_niceness_of_0_to_19_passes_both_checks(value: int) -> None:
    assert check_niceness(value, "the planner's") == value == niceness_argument(str(value))


@pytest.mark.parametrize("value", [-1, MAX_NICENESS + 1])
def test_a_niceness_out_of_range_is_refused_naming_whose_it_is(value: int) -> None:
    with pytest.raises(ValueError, match=f"the load's niceness must be 0-19, got {value}"):
        check_niceness(value, "the load's")
    with pytest.raises(argparse.ArgumentTypeError, match="must be 0-19"):
        niceness_argument(str(value))


def test_lowering_by_nothing_reports_the_niceness_the_process_runs_at() -> None:
    assert lower_priority(0) == os.nice(0)  # this test process is not lowered
