"""GCRLB of zuo2021 eq. (15)-(24) against numerical Fisher information, and section 3's geometry claims.

The likelihood used as the oracle is written here from eq. (1)-(2) with plain
formulas, independently of ``SensorModel`` and ``gcs.core.gcrlb``. Section 3's
claims are checked by minimising ``tr(GCRLB)`` with scipy.optimize; where the paper
is wrong or garbled the test asserts the corrected statement and says so.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize

from gcs.core.gcrlb import (
    fisher_information,
    gcrlb,
    gcrlb_trace,
    optimal_trace,
    planar_fisher_information,
    trace_from_angles,
    tracking_gcrlb,
)
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.pcrlb import pcrlb

SIGMA0 = math.radians(1.0)
R0 = 1500.0
BETA = SIGMA0**2 / R0**2
AOA = SensorModel.bearing_only(SIGMA0, distance_dependent=True, reference_range_m=R0)


# --- the oracle: eq. (1)-(2) written out ------------------------------------------------------


def _mean_and_variance(p: np.ndarray, vehicles: np.ndarray, sigma0: np.ndarray, elevation: bool) -> tuple[np.ndarray, ...]:
    """Azimuth (and elevation) of target p (..., 2) from vehicles (M, 3), and eq. (2) variances."""
    dx = p[..., None, 0] - vehicles[:, 0]
    dy = p[..., None, 1] - vehicles[:, 1]
    dz = -vehicles[:, 2] + 0.0 * dx
    rho = np.sqrt(dx**2 + dy**2 + dz**2)
    scale = np.maximum(rho / R0, 1.0) ** 2
    mean = [np.arctan2(dy, dx)]
    var = [sigma0**2 * scale]
    if elevation:
        mean.append(np.arctan2(dz, np.hypot(dx, dy)))
        var.append((2.0 * sigma0) ** 2 * scale)
    return np.concatenate(mean, -1), np.concatenate(var, -1)


def _expected_log_likelihood(p_true: np.ndarray, p: np.ndarray, vehicles, sigma0, elevation=False) -> float:
    """E_z[log N(z; h(p), R(p))] for z ~ N(h(p_true), R(p_true)), in closed form."""
    m0, v0 = _mean_and_variance(p_true, vehicles, sigma0, elevation)
    m, v = _mean_and_variance(p, vehicles, sigma0, elevation)
    return float(np.sum(-0.5 * np.log(v) - (v0 + (m0 - m) ** 2) / (2.0 * v)))


def _expected_hessian_information(p, vehicles, sigma0, elevation=False, step=0.5) -> np.ndarray:
    """-Hessian of the expected log-likelihood at the truth (central differences): the Fisher information."""
    info = np.zeros((2, 2))
    e = np.eye(2) * step
    for a in range(2):
        for b in range(2):
            ell = [_expected_log_likelihood(p, p + da * e[a] + db * e[b], vehicles, sigma0, elevation)
                   for da, db in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
            info[a, b] = -(ell[0] - ell[1] - ell[2] + ell[3]) / (4.0 * step * step)
    return info


def _planar(bearings: np.ndarray, ranges: np.ndarray, target=(0.0, 0.0)) -> np.ndarray:
    """Sensor positions (M, 3) that see the target at ``bearings`` (eq. 1) from ``ranges``."""
    t = np.asarray(target)
    xy = t - ranges[:, None] * np.stack([np.cos(bearings), np.sin(bearings)], -1)
    return np.column_stack([xy, np.zeros(len(bearings))])


def _trace_at(bearings: np.ndarray, ranges: np.ndarray) -> float:
    """tr(GCRLB) (eq. 24) for sensors at ``ranges`` on ``bearings`` from the target."""
    return float(gcrlb_trace([AOA] * len(bearings), np.zeros(2), _planar(np.asarray(bearings), np.asarray(ranges))))


def _fast_trace(bearings: np.ndarray, ranges: np.ndarray) -> float:
    """The same through the closed form of eq. (18)-(21) (equal to it: test_closed_forms_...), for the optimisers."""
    assert np.all(np.asarray(ranges) > R0)  # the closed form holds beyond r0
    info = planar_fisher_information(np.asarray(bearings), np.asarray(ranges), BETA)
    return float(np.trace(info) / np.linalg.det(info))


# --- eq. (15)-(17) against numerical Fisher information ---------------------------------------


def test_fisher_information_equals_the_expected_hessian_of_the_log_likelihood() -> None:
    """Planar, eq. (16)-(17), with sensors beyond and inside r0 and unequal sigma0 (Fig. 8's 1 / 0.8 / 0.1 deg)."""
    target = np.array([10000.0, 3000.0])
    vehicles = np.array([[1000.0, 1000.0, 0.0], [2000.0, 0.0, 0.0], [9000.0, 2500.0, 0.0]])  # the third within r0
    sigma0 = np.radians([1.0, 0.8, 0.1])
    sensors = [SensorModel.bearing_only(s, distance_dependent=True, reference_range_m=R0) for s in sigma0]
    expected = _expected_hessian_information(target, vehicles, sigma0)
    np.testing.assert_allclose(fisher_information(sensors, target, vehicles), expected, rtol=1e-5)


def test_the_variance_term_j2_is_needed_and_is_two_over_r_squared_along_the_line_of_sight() -> None:
    target = np.array([6000.0, -2000.0])
    vehicles = _planar(np.array([0.3]), np.array([5000.0]), target)
    info = fisher_information([AOA], target, vehicles)
    v = np.array([math.cos(0.3), math.sin(0.3)])
    u = np.array([-math.sin(0.3), math.cos(0.3)])
    j1 = np.outer(u, u) / (BETA * 5000.0**4)  # eq. (16)
    j2 = 2.0 / 5000.0**2 * np.outer(v, v)  # eq. (17)
    np.testing.assert_allclose(info, j1 + j2, rtol=1e-9)
    assert np.linalg.matrix_rank(info) == 2  # one sensor localises: the noise level carries range information
    constant = SensorModel.bearing_only(SIGMA0)
    assert np.linalg.matrix_rank(fisher_information([constant], target, vehicles), tol=1e-12) == 1


def test_three_dimensional_general_form_matches_the_expected_hessian() -> None:
    """Azimuth + elevation from aircraft at altitude: J2 = (m/2) grad log s grad log s^T with the 3-D range."""
    target = np.array([4000.0, 2500.0])
    vehicles = np.array([[1000.0, 1000.0, 300.0], [2500.0, -500.0, 250.0]])
    sensor = SensorModel.bearing_only(SIGMA0, 2.0 * SIGMA0, distance_dependent=True, reference_range_m=R0)
    expected = _expected_hessian_information(target, vehicles, np.array([SIGMA0, SIGMA0]), elevation=True)
    np.testing.assert_allclose(fisher_information([sensor, sensor], target, vehicles), expected, rtol=1e-5)


def test_fisher_information_equals_the_covariance_of_the_score_monte_carlo() -> None:
    rng = np.random.default_rng(15)
    target = np.array([7000.0, 2000.0])
    vehicles = np.array([[1000.0, 1000.0, 0.0], [2000.0, 0.0, 0.0], [1000.0, -1000.0, 0.0]])
    sigma0 = np.full(3, SIGMA0)
    mean, var = _mean_and_variance(target, vehicles, sigma0, False)
    z = mean + np.sqrt(var) * rng.standard_normal((40_000, 3))

    def log_likelihood(p: np.ndarray) -> np.ndarray:
        m, v = _mean_and_variance(p, vehicles, sigma0, False)
        return np.sum(-0.5 * np.log(v) - (z - m) ** 2 / (2.0 * v), axis=-1)

    step = 0.05
    score = np.stack(
        [(log_likelihood(target + step * e) - log_likelihood(target - step * e)) / (2 * step) for e in np.eye(2)], -1
    )
    empirical = score.T @ score / len(score)
    info = fisher_information([AOA] * 3, target, vehicles)
    # Compare in the information's own metric: J^-1/2 S J^-1/2 = I within Monte Carlo error (~1 %).
    w = np.linalg.cholesky(np.linalg.inv(info))
    np.testing.assert_allclose(w.T @ empirical @ w, np.eye(2), atol=0.04)
    assert np.abs(score.mean(axis=0) @ w).max() < 0.03  # E[score] = 0


# --- eq. (18)-(25): the closed forms -----------------------------------------------------------


def test_closed_forms_eq18_to_eq24_match_the_general_information() -> None:
    rng = np.random.default_rng(18)
    for m in range(1, 7):
        bearings = rng.uniform(-math.pi, math.pi, m)
        ranges = rng.uniform(2000.0, 30000.0, m)
        beta = np.full(m, BETA)
        info = planar_fisher_information(bearings, ranges, beta)
        vehicles = _planar(bearings, ranges, (300.0, -200.0))
        np.testing.assert_allclose(info, fisher_information([AOA] * m, np.array([300.0, -200.0]), vehicles), rtol=1e-9)
        a, b = 2.0 / ranges**2, 1.0 / (beta * ranges**4)
        c, d = a + b, a - b
        big_a, b1, b2 = c.sum(), (d * np.cos(2 * bearings)).sum(), (d * np.sin(2 * bearings)).sum()
        assert np.linalg.det(info) == pytest.approx((big_a**2 - b1**2 - b2**2) / 4.0, rel=1e-9)  # eq. (22)
        trace = np.trace(gcrlb([AOA] * m, np.array([300.0, -200.0]), vehicles))  # eq. (23)
        assert trace == pytest.approx(4.0 * big_a / (big_a**2 - b1**2 - b2**2), rel=1e-9)  # eq. (24)
        assert trace_from_angles(bearings, ranges, beta) == pytest.approx(trace, rel=1e-9)  # eq. (25), corrected


def test_eq25_as_printed_drops_angle_free_cross_terms() -> None:
    """Eq. (25) printed: f = sum c / (sum a b + sum d_i d_j sin^2 phi_ij); it misses sum_{i<j} (a_i b_j + a_j b_i)."""
    bearings, ranges = np.array([0.0, 1.0, 2.0]), np.array([4000.0, 6000.0, 9000.0])
    a, b = 2.0 / ranges**2, 1.0 / (BETA * ranges**4)
    c, d = a + b, a - b
    pairs = [(i, j) for i in range(3) for j in range(i + 1, 3)]
    angular = sum(d[i] * d[j] * math.sin(bearings[j] - bearings[i]) ** 2 for i, j in pairs)
    printed = c.sum() / ((a * b).sum() + angular)
    true = _trace_at(bearings, ranges)
    assert abs(printed / true - 1.0) > 0.01
    cross = sum(a[i] * b[j] + a[j] * b[i] for i, j in pairs)
    corrected = c.sum() / ((a * b).sum() + cross + angular)
    assert corrected == pytest.approx(true, rel=1e-9)


# --- section 3.2: unconstrained optimal angles and ranges -------------------------------------


def _best_angles(
    ranges: np.ndarray, bounds: tuple[float, float] | None = None, starts: int = 12, seed: int = 3
) -> tuple[float, np.ndarray]:
    """min over the bearings of tr(GCRLB) (theta_1 = 0 unless bounded), multi-start scipy.optimize."""
    rng = np.random.default_rng(seed)
    m = len(ranges)
    best = (math.inf, np.zeros(m))
    for _ in range(starts):
        if bounds is None:
            x0 = rng.uniform(0.0, math.pi, m - 1)
            res = minimize(lambda t: _fast_trace(np.r_[0.0, t], ranges), x0, method="BFGS")
            angles = np.r_[0.0, res.x]
        else:
            x0 = rng.uniform(*bounds, m)
            res = minimize(lambda t: _fast_trace(t, ranges), x0, method="L-BFGS-B", bounds=[bounds] * m)
            angles = res.x
        if res.fun < best[0]:
            best = (float(res.fun), angles)
    return best


def _separations(angles: np.ndarray) -> np.ndarray:
    """Gaps between the bearing lines' directions on the circle mod pi (they sum to pi)."""
    mod = np.sort(np.mod(angles, math.pi))
    return np.diff(np.r_[mod, mod[0] + math.pi])


@pytest.mark.parametrize("ranges", [(5000.0, 5000.0), (3000.0, 12000.0)])
def test_two_sensors_are_best_at_right_angles_for_any_ranges(ranges: tuple[float, float]) -> None:
    """Eq. (27): phi_12 = +-pi/2 (the printed derivative '2 d_1 d_1 sin 2 phi' should read d_1 d_2 sin 2 phi)."""
    _, angles = _best_angles(np.array(ranges))
    assert abs(math.sin(angles[1] - angles[0])) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("m", [3, 4, 5, 6])
def test_equal_ranges_optimum_is_the_pi_over_m_spacing(m: int) -> None:
    """Eq. (31) and section 3.3: optimal value 4 beta r^4 / (M (2 beta r^2 + 1)) at the sensors' range
    (the paper prints r_max for r_min), reached with the lines pi/M apart (B_1 = B_2 = 0)."""
    r = 6000.0
    value, angles = _best_angles(np.full(m, r))
    assert value == pytest.approx(optimal_trace(m, r, SIGMA0, R0), rel=1e-8)
    assert abs(np.exp(2j * angles).sum()) < 1e-3
    assert _trace_at(np.arange(m) * math.pi / m, np.full(m, r)) == pytest.approx(value, rel=1e-9)
    if m == 3:  # unique up to rotation: the three lines are exactly pi/3 apart
        np.testing.assert_allclose(_separations(angles), math.pi / 3, atol=1e-3)


def test_three_sensors_cannot_be_pairwise_perpendicular_and_their_optimum_depends_on_range() -> None:
    """Section 3.2 (b) claims phi_ij = +-pi/2 for all pairs and an optimum independent of r_i; both fail for M = 3."""
    r = np.full(3, 6000.0)
    spaced = _trace_at(np.array([0.0, math.pi / 3, 2 * math.pi / 3]), r)
    assert _trace_at(np.array([0.0, math.pi / 2, math.pi / 2]), r) > 1.05 * spaced
    unequal = np.array([5000.0, 5500.0, 6000.0])
    _, angles = _best_angles(unequal)
    assert np.abs(_separations(angles) - math.pi / 3).max() > math.radians(3.0)


def test_closer_is_better_beyond_r0_so_the_optimal_range_is_r_min() -> None:
    """Eq. (29) and section 3.3: at fixed angles the trace grows with every r_i; scipy finds r_i = r_min."""
    bearings = np.array([0.0, math.pi / 3, 2 * math.pi / 3])
    grid = np.linspace(1600.0, 20000.0, 60)
    for i in range(3):
        traces = [_trace_at(bearings, np.where(np.arange(3) == i, r, 7000.0)) for r in grid]
        assert np.all(np.diff(traces) > 0.0)
    for r_min in (2000.0, 500.0):  # beyond and inside r0
        bounds = [(r_min, 20000.0)] * 3
        res = minimize(lambda r: _trace_at(bearings, r), np.full(3, 9000.0), method="L-BFGS-B", bounds=bounds)
        np.testing.assert_allclose(res.x, r_min, rtol=1e-6)


def test_the_bound_jumps_at_r0_where_the_variance_stops_depending_on_range() -> None:
    """Not in the paper: eq. (2) is flat inside r0, so J2 vanishes there; for two perpendicular sensors
    the trace just inside r0 is (1 + 2 sigma0^2) times the trace just outside."""
    bearings = np.array([0.0, math.pi / 2])
    outside = _trace_at(bearings, np.full(2, R0 * (1 + 1e-9)))
    inside = _trace_at(bearings, np.full(2, R0 * (1 - 1e-9)))
    assert inside / outside == pytest.approx(1.0 + 2.0 * SIGMA0**2, rel=1e-6)


# --- section 3.3: angle sectors ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("m", "width", "reachable"),
    [(2, math.pi / 2, True), (2, 1.2, False), (3, 2.2, True), (3, 1.5, False)],
)
def test_in_a_sector_the_optimum_is_reachable_only_if_it_spans_m_minus_one_pi_over_m(
    m: int, width: float, reachable: bool
) -> None:
    """Eq. (32)-(33) claim the pi/M spacing for any sector wider than pi/M; it needs (M - 1) pi / M.
    (For M = 3 a sector of 1.5 rad > pi/3 does not reach the unconstrained optimum.)"""
    r_min = 4000.0
    value, angles = _best_angles(np.full(m, r_min), bounds=(0.0, width))
    best = optimal_trace(m, r_min, SIGMA0, R0)
    assert np.all((angles >= -1e-9) & (angles <= width + 1e-9))
    if reachable:
        assert value == pytest.approx(best, rel=1e-7)
    else:
        assert value > 1.01 * best


# --- the tracking bound ------------------------------------------------------------------------


def test_tracking_bound_with_constant_noise_equals_the_tichavsky_pcrlb() -> None:
    motion = constant_velocity(0.05)
    k = 12
    truth = np.array([5000.0, 2000.0, -4.0, 3.0]) + np.outer(np.arange(k), [-4.0, 3.0, 0.0, 0.0])
    vehicles = np.stack([_planar(np.array([0.2, 0.9]), np.array([4000.0, 3000.0]), t[:2]) for t in truth])
    p0 = np.diag([1e6, 1e6, 25.0, 25.0])
    constant = SensorModel.bearing_only(SIGMA0)
    ours = tracking_gcrlb(motion, 1.0, np.linalg.inv(p0), [constant] * 2, vehicles, truth)
    reference = pcrlb(motion, 1.0, p0, [constant] * 2, vehicles, np.ones((k, 2), bool), truth)
    np.testing.assert_allclose(ours, reference, rtol=1e-8)
    # With eq. (2) the variance term adds information: the generalised bound is below the J1-only one.
    ours = tracking_gcrlb(motion, 1.0, np.linalg.inv(p0), [AOA] * 2, vehicles, truth)
    j1_only = pcrlb(motion, 1.0, p0, [AOA] * 2, vehicles, np.ones((k, 2), bool), truth)
    assert np.all(np.linalg.eigvalsh(j1_only - ours) > -1e-9)
    assert np.trace(ours[-1]) < np.trace(j1_only[-1])
