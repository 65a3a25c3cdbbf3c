"""Simulated GPS: white noise and Gauss-Markov bias statistics, reported sigma, denied zones."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
from scipy.stats import chi2

from gcs.config.simulation import GpsConfig, GpsDeniedZone
from gcs.scenarios import load_scenario
from sim_vehicles.truth.gps import FIX_3D, FIX_NONE, GpsModel

ALPHA = 1e-4
"""Two-sided false-alarm probability of every statistical check."""
Z = 4.42
"""Two-sided normal bound for 1e-5."""


def _assert_chi2(squares: np.ndarray, what: str) -> None:
    lo, hi = chi2.ppf([ALPHA / 2, 1 - ALPHA / 2], squares.size)
    assert lo < squares.sum() < hi, f"{what}: chi-square {squares.sum():.1f} outside [{lo:.1f}, {hi:.1f}] ({squares.size} dof)"


def test_white_noise_matches_the_configured_sigma_per_axis() -> None:
    model = GpsModel(GpsConfig(horizontal_std_m=2.0, vertical_std_m=3.0, bias_std_m=0.0, satellites=9))
    rng = np.random.default_rng(11)
    state = model.start(rng)
    truth = np.array([100.0, -50.0, 120.0])
    residuals = np.empty((3000, 3))
    for k in range(len(residuals)):
        state, reading = model.read(state, truth, 1.0, rng)
        residuals[k] = reading.position_enu_m - truth
    assert np.all(state.bias_enu_m == 0.0)
    assert (reading.fix_type, reading.satellites) == (FIX_3D, 9)
    assert (reading.horizontal_std_m, reading.vertical_std_m) == (2.0, 3.0)
    normalised = residuals / np.array([2.0, 2.0, 3.0])
    for axis, name in enumerate("ENU"):
        _assert_chi2(normalised[:, axis] ** 2, f"{name} noise")
    assert np.all(np.abs(normalised.mean(axis=0)) < Z / math.sqrt(len(residuals)))


def test_bias_is_a_stationary_first_order_gauss_markov_process() -> None:
    sigma_b, tau, dt = 1.5, 60.0, 30.0
    cfg = GpsConfig(horizontal_std_m=2.0, vertical_std_m=3.0, bias_std_m=sigma_b, bias_time_constant_s=tau)
    model = GpsModel(cfg)
    rng = np.random.default_rng(12)
    chains = 2000
    b0, b1, residual = np.empty((chains, 3)), np.empty((chains, 3)), np.empty((chains, 3))
    truth = np.array([10.0, 20.0, 300.0])
    for c in range(chains):  # independent chains, each started in the stationary distribution
        s0 = model.start(rng)
        s1, reading = model.read(s0, truth, dt, rng)
        b0[c], b1[c], residual[c] = s0.bias_enu_m, s1.bias_enu_m, reading.position_enu_m - truth
    phi = math.exp(-dt / tau)
    _assert_chi2((b0 / sigma_b) ** 2, "initial bias variance")
    _assert_chi2((b1 / sigma_b) ** 2, "bias variance after a step")
    _assert_chi2(((b1 - phi * b0) / (sigma_b * math.sqrt(1 - phi**2))) ** 2, "Gauss-Markov driving noise")
    # Lag-1 autocorrelation phi, by Fisher's z.
    r = np.sum(b0 * b1) / math.sqrt(np.sum(b0**2) * np.sum(b1**2))
    assert abs(math.atanh(r) - math.atanh(phi)) < Z / math.sqrt(b0.size - 3)
    # The reading carries the bias plus white noise, and the reported sigma is the total.
    _assert_chi2(((residual - b1) / np.array([2.0, 2.0, 3.0])) ** 2, "white noise on top of the bias")
    reported = np.array([reading.horizontal_std_m, reading.horizontal_std_m, reading.vertical_std_m])
    np.testing.assert_allclose(reported, np.hypot([2.0, 2.0, 3.0], sigma_b))
    _assert_chi2((residual / reported) ** 2, "total error against the reported sigma")


def test_the_bias_barely_moves_over_a_short_step() -> None:
    model = GpsModel(GpsConfig(bias_std_m=2.0, bias_time_constant_s=1000.0))
    rng = np.random.default_rng(13)
    state = model.start(rng)
    after, _ = model.read(state, np.zeros(3), 0.0, rng)
    np.testing.assert_array_equal(after.bias_enu_m, state.bias_enu_m)  # dt = 0: phi = 1, no driving noise
    with pytest.raises(ValueError, match="dt_s"):
        model.read(state, np.zeros(3), -1.0, rng)


L_SHAPE = np.array([[0.0, 0.0], [200.0, 0.0], [200.0, 100.0], [100.0, 100.0], [100.0, 200.0], [0.0, 200.0]])
SQUARE = np.array([[1000.0, 1000.0], [1100.0, 1000.0], [1100.0, 1100.0], [1000.0, 1100.0]])


@pytest.mark.parametrize(
    ("xy", "denied"),
    [((50.0, 50.0), True), ((50.0, 150.0), True), ((150.0, 50.0), True), ((1050.0, 1050.0), True),
     ((150.0, 150.0), False), ((300.0, 300.0), False), ((-10.0, 50.0), False), ((1050.0, 900.0), False)],
)
def test_no_fix_inside_a_denied_polygon(xy: tuple[float, float], denied: bool) -> None:
    model = GpsModel(GpsConfig(satellites=10), (L_SHAPE, SQUARE))
    rng = np.random.default_rng(14)
    _, reading = model.read(model.start(rng), np.array([xy[0], xy[1], 150.0]), 1.0, rng)
    if denied:
        assert (reading.position_enu_m, reading.fix_type, reading.satellites) == (None, FIX_NONE, 0)
    else:
        assert (reading.fix_type, reading.satellites) == (FIX_3D, 10)
        assert np.linalg.norm(reading.position_enu_m - [xy[0], xy[1], 150.0]) < 30.0


def test_a_denied_zone_changes_the_readings_only() -> None:
    everywhere = GpsModel(GpsConfig(), ([[-1e5, -1e5], [1e5, -1e5], [1e5, 1e5], [-1e5, 1e5]],))
    nowhere = GpsModel(GpsConfig())
    states = []
    for model in (everywhere, nowhere):
        rng = np.random.default_rng(15)
        state = model.start(rng)
        for _ in range(5):
            state, reading = model.read(state, np.zeros(3), 1.0, rng)
        states.append((state.bias_enu_m, reading))
    np.testing.assert_array_equal(states[0][0], states[1][0])
    assert states[0][1].position_enu_m is None and states[1][1].position_enu_m is not None


def test_from_scenario_takes_the_simulation_gps_and_the_denied_zones() -> None:
    base = load_scenario("wang2012_urban")
    gps = GpsConfig(horizontal_std_m=4.0, bias_std_m=0.5)
    scenario = msgspec.structs.replace(
        base, simulation=msgspec.structs.replace(base.simulation, gps=gps),
        gps_denied=[GpsDeniedZone(name="tunnel", polygon_enu_m=[(0.0, 0.0), (100.0, 0.0), (100.0, 100.0)])],
    )
    model = GpsModel.from_scenario(scenario)
    assert model.config == gps
    np.testing.assert_array_equal(model.denied_at([[80.0, 10.0], [10.0, 80.0]]), [True, False])
    assert not GpsModel.from_scenario(base).denied_at([[80.0, 10.0]]).any()


def test_a_degenerate_denied_polygon_is_rejected() -> None:
    with pytest.raises(ValueError, match="GPS-denied polygon 0"):
        GpsModel(GpsConfig(), ([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]],))
