"""The in-process loop with the vehicles' own navigation (gcs-bench urban --gps-denied): their reported
positions, or the engine's SKF on their nav reports."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from benchmarks.urban import run_closed_loop
from benchmarks.urban_nav_report import DEFAULT_ZONE, summarise, with_gps_denied
from gcs.config.world import build_world
from gcs.scenarios import load_scenario

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
DENIED = with_gps_denied(SCENARIO)


def _run(scenario, navigation, duration: float = 40.0, seed: int = 3):
    return run_closed_loop(scenario, WORLD, "orbit", seed, duration_s=duration, clock=None, navigation=navigation)


def test_perfect_navigation_is_the_loop_without_navigation() -> None:
    plain = run_closed_loop(SCENARIO, WORLD, "orbit", 3, duration_s=40.0, clock=None)  # no zone: no GPS flown
    perfect = _run(DENIED, "perfect")
    np.testing.assert_array_equal(perfect.errors_m, plain.errors_m)  # the GPS and INS draws touch nothing else
    np.testing.assert_array_equal(perfect.vehicle_xy, plain.vehicle_xy)
    assert plain.nav_error_m is None and plain.gps_fix is None
    assert not perfect.nav_error_m.any() and not perfect.gps_fix[1:].any()  # the outages, for the comparison


def test_with_gps_the_navigations_follow_the_fix_and_the_skf_filters_its_noise() -> None:
    """The reported position with a fix is the fix, with the receiver's whole error: per axis white noise and
    bias, sqrt(2 (sigma_n^2 + sigma_b^2)) horizontally. The SKF (GPS + INS) averages the white noise out but
    cannot see the bias, which is common to every fix: its error lies between the bias's sqrt(2) sigma_b and
    most of the raw error."""
    assert not SCENARIO.gps_denied
    gps = SCENARIO.simulation.gps
    raw_expected = np.sqrt(2.0 * (gps.horizontal_std_m**2 + gps.bias_std_m**2))
    bias_floor = np.sqrt(2.0) * gps.bias_std_m
    errors = {}
    for navigation in ("reported", "skf"):
        record = _run(SCENARIO, navigation)
        assert record.gps_fix.all()
        errors[navigation] = float(np.sqrt(np.mean(record.nav_error_m[1:] ** 2)))
    # 40 s x 3 vehicles: the white noise's share is well sampled, the slow bias's (6 draws) less so
    assert 0.8 * raw_expected < errors["reported"] < 1.25 * raw_expected, (errors, raw_expected)
    assert 0.5 * bias_floor < errors["skf"] < 0.8 * errors["reported"], (errors, bias_floor)


@pytest.mark.parametrize("navigation", ["reported", "skf"])
def test_in_the_denied_zone_navigation_drifts_and_the_track_holds(navigation: str) -> None:
    record = _run(DENIED, navigation, duration=60.0)
    assert record.gps_fix[0].all()  # the fix each vehicle flew in with
    assert not record.gps_fix[1:].any()  # the default zone covers the UAVs' start and their loiter
    assert record.nav_error_m[-10:].mean() > record.nav_error_m[1:6].mean()  # dead reckoning drifts
    assert record.rmse_m < 30.0
    summary = summarise([record])
    assert summary["outage_steps_mean"] == 59 and summary["nav_rmse_outage_m"] > 0


def test_scenario_zones_are_kept_and_the_default_added_otherwise() -> None:
    assert DENIED.gps_denied == [DEFAULT_ZONE]
    own = msgspec.structs.replace(SCENARIO, gps_denied=[msgspec.structs.replace(DEFAULT_ZONE, name="mine")])
    assert with_gps_denied(own).gps_denied[0].name == "mine"
    with pytest.raises(ValueError, match="unknown navigation"):
        _run(SCENARIO, "ins_only", duration=2.0)
