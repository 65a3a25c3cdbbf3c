"""feng2019's navigation SKF (INS eq. 1, GPS eq. 4-5, map eq. 2-3), centralised and distributed."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
from scipy.stats import chi2

from gcs.config.simulation import GpsConfig, InsConfig
from gcs.core.filters.kalman import Observation, kalman_update
from gcs.core.geometry import LocalFrame, wrap_angle
from gcs.core.navigation.federated import federated_start, federated_update, fuse_estimates
from gcs.core.navigation.model import THETA, InsNoise, ins_predict
from gcs.core.navigation.route import (OFF_ROUTE, RouteSegment, TransitionModel, candidate_segments,
                                       map_observation, route_segments, transition_matrix)
from gcs.core.navigation.skf import (NavMeasurement, NavParams, from_gaussian, initial, nav_measurement, nav_update,
                                     position, position_at)
from gcs.scenarios import load_scenario
from protocols.messages import GpsFix, InsIncrement, NavReport
from sim_vehicles.truth.gps import GpsModel
from sim_vehicles.truth.ins import InsModel

NS = 1_000_000_000


def _circle(t: float, speed: float = 25.0, rate: float = 0.05) -> tuple[np.ndarray, float]:
    """Truth on a circle through the origin, heading 0 at t = 0: position (2,), heading."""
    radius = speed / rate
    heading = rate * t
    return np.array([radius * math.sin(heading), radius * (1.0 - math.cos(heading))]), heading


def test_ins_prediction_jacobians_match_finite_differences() -> None:
    mean = np.array([10.0, -5.0, 0.7, 20.0, 3.0, 0.02])
    ds, dth, dt = 24.0, 0.08, 1.0
    silent = InsNoise(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def f(state: np.ndarray, u: np.ndarray) -> np.ndarray:
        out, _ = ins_predict(state, np.zeros((6, 6)), u[0], u[1], dt, silent)
        return out

    eps = 1e-6
    jac_x = np.column_stack([(f(mean + eps * e, [ds, dth]) - f(mean - eps * e, [ds, dth])) / (2 * eps) for e in np.eye(6)])
    jac_u = np.column_stack([(f(mean, np.array([ds, dth]) + eps * e) - f(mean, np.array([ds, dth]) - eps * e)) / (2 * eps)
                             for e in np.eye(2)])
    cov = np.diag([4.0, 9.0, 0.01, 1.0, 2.0, 0.001])
    _, predicted = ins_predict(mean, cov, ds, dth, dt, silent)
    np.testing.assert_allclose(predicted, jac_x @ cov @ jac_x.T, rtol=1e-6, atol=1e-9)
    noise = InsNoise(distance_std_m=0.7, distance_scale_std=0.0, heading_std_rad=0.003, heading_drift_std_rad_s=0.0,
                     position_std_m=0.0, velocity_std_mps=0.0, turn_rate_std_rad_s=0.0)
    _, from_inputs = ins_predict(mean, np.zeros((6, 6)), ds, dth, dt, noise)
    np.testing.assert_allclose(from_inputs, jac_u @ np.diag([0.7**2, 0.003**2]) @ jac_u.T, rtol=1e-6, atol=1e-12)


def test_noiseless_increments_dead_reckon_a_circle_exactly() -> None:
    """Eq. (1) is exact for an arc when delta_s is its chord: no GPS, no error after 2 minutes of turning."""
    params = NavParams()
    start, heading = _circle(0.0)
    estimate = initial(params, 0, start, 1.0, heading, [25.0, 0.0])
    for k in range(1, 121):
        before, _ = _circle(k - 1.0)
        after, heading = _circle(float(k))
        chord = float(np.hypot(*(after - before)))
        estimate = nav_update(params, estimate, NavMeasurement(k * NS, ins=(chord, 0.05, 1.0)))
    assert np.hypot(*(estimate.mean[:2] - after)) < 1e-6
    assert abs(wrap_angle(estimate.mean[THETA] - heading)) < 1e-12
    assert estimate.mean[5] == pytest.approx(0.05)


def test_noiseless_gps_and_route_give_zero_error_and_the_right_segment() -> None:
    params = NavParams()
    route = route_segments([[x, 0.0] for x in np.arange(-200.0, 4000.0, 150.0)])
    estimate = initial(params, 0, [0.0, 0.0], 3.0, 0.0, [25.0, 0.0])
    for k in range(1, 61):
        truth = np.array([25.0 * k, 0.0])
        estimate = nav_update(params, estimate, NavMeasurement(k * NS, ins=(25.0, 0.0, 1.0), gps_xy=truth, gps_std_m=2.0),
                              route)
    # Millimetres, not zero: the neighbouring segments' modes project onto their ends (eq. 2 clamped),
    # an along-track pull of delta_y^-2-weighted tens of metres, which the exact GPS undoes.
    assert np.hypot(*(estimate.mean[:2] - truth)) < 0.01
    on_segment = [s.key for s in route if s.start[0] <= truth[0] <= s.end[0]]
    assert max(estimate.probabilities, key=estimate.probabilities.get) in on_segment
    assert estimate.probabilities[OFF_ROUTE] < 0.01


def _monte_carlo(runs: int, steps: int, seed: int, route=()) -> tuple[np.ndarray, np.ndarray]:
    """NEES (runs, steps) of CF and DF on a circle, INS and GPS from the simulator's models (white noise only)."""
    ins = InsModel(InsConfig(distance_scale_error=0.0, distance_std_m=0.5, heading_drift_rad_s=0.0, heading_std_rad=0.003))
    gps = GpsModel(GpsConfig(horizontal_std_m=3.0, bias_std_m=0.0))
    # The filter's noise matches the truth's; the initial heading is good to 0.01 rad (with 0.1 rad the
    # dead-reckoning local filter of DF is visibly non-linear: its position error is the heading error
    # times a lever arm of up to a kilometre, second-order terms included).
    params = NavParams(initial_heading_std_rad=0.01,
                       ins=InsNoise(distance_std_m=0.5, distance_scale_std=1e-6, heading_std_rad=0.003,
                                    heading_drift_std_rad_s=1e-7, position_std_m=1e-3, velocity_std_mps=1e-2,
                                    turn_rate_std_rad_s=1e-4))
    nees = np.zeros((2, runs, steps))
    for run in range(runs):
        rng = np.random.default_rng([seed, run])
        start, heading = _circle(0.0)
        x0 = np.array([*start, heading, 25.0, 0.0, 0.05])
        p0 = np.diag([3.0, 3.0, params.initial_heading_std_rad, params.initial_velocity_std_mps,
                      params.initial_velocity_std_mps, params.initial_turn_std_rad_s]) ** 2
        draw = x0 + rng.multivariate_normal(np.zeros(6), p0)
        cf = from_gaussian(0, draw, p0)
        df = federated_start(cf)
        state = gps.start(rng)
        for k in range(1, steps + 1):
            before, _ = _circle(k - 1.0)
            after, heading = _circle(float(k))
            distance, turn = ins.increment(25.0, 0.05, 1.0, rng)
            state, reading = gps.read(state, np.append(after, 100.0), 1.0, rng)
            m = NavMeasurement(k * NS, ins=(distance, turn, 1.0), gps_xy=reading.position_enu_m[:2],
                               gps_std_m=reading.horizontal_std_m)
            cf = nav_update(params, cf, m, route)
            df = federated_update(params, df, m, route)
            truth = np.array([*after, heading, 25.0 * math.cos(heading), 25.0 * math.sin(heading), 0.05])
            for n, estimate in enumerate((cf, df)):
                error = estimate.mean - truth
                error[THETA] = wrap_angle(error[THETA])
                nees[n, run, k - 1] = error @ np.linalg.solve(estimate.cov, error)
    return nees[0], nees[1]


def test_cf_nees_is_inside_its_chi_square_band_and_df_is_conservative() -> None:
    runs, steps = 30, 30
    cf, df = _monte_carlo(runs, steps, seed=9)
    lo, hi = chi2.ppf([0.0005, 0.9995], 6 * runs) / runs  # the run-average NEES of a consistent filter
    assert lo < cf[:, 10:].mean() < hi, (lo, cf[:, 10:].mean(), hi)
    assert df[:, 10:].mean() < hi  # Carlson's no-reset federated filter: an upper bound on the error


def test_fusion_centre_is_the_product_of_the_two_gaussians() -> None:
    rng = np.random.default_rng(3)
    roots = rng.normal(size=(2, 6, 6))
    cov_a, cov_b = roots[0] @ roots[0].T + np.eye(6), roots[1] @ roots[1].T + np.eye(6)
    mean_a, mean_b = rng.normal(size=6), rng.normal(size=6)
    mean, cov = fuse_estimates(mean_a, cov_a, mean_b, cov_b)
    # Independent route: estimate b as an observation of the state with H = I, R = cov_b.
    ref_mean, ref_cov, _ = kalman_update(mean_a, cov_a, Observation(mean_b, np.eye(6), cov_b, angle_rows=(THETA,)))
    np.testing.assert_allclose(mean, ref_mean, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(cov, ref_cov, rtol=1e-8, atol=1e-10)


def test_heading_picks_the_segment_at_a_crossing() -> None:
    """Two segments cross where the vehicle is; it flies east without GPS: the east segment wins."""
    params = NavParams()
    east = RouteSegment(0, (-300.0, 0.0), (600.0, 0.0))
    north = RouteSegment(5, (0.0, -300.0), (0.0, 600.0))
    estimate = initial(params, 0, [0.0, 0.0], 5.0, 0.0, [25.0, 0.0])
    for k in range(1, 4):
        estimate = nav_update(params, estimate, NavMeasurement(k * NS, ins=(25.0, 0.0, 1.0)), (east, north))
    assert estimate.probabilities[0] > 0.9
    assert estimate.probabilities.get(5, 0.0) < 0.05


def test_the_route_bounds_the_drift_without_gps() -> None:
    """Gyro drift of 0.003 rad/s for 150 s without GPS: the route keeps the cross-track error small."""
    base = load_scenario("wang2012_urban")
    scenario = msgspec.structs.replace(base, simulation=msgspec.structs.replace(
        base.simulation, ins=InsConfig(heading_drift_rad_s=0.003)))
    params = NavParams.from_scenario(scenario)
    ins = InsModel(scenario.simulation.ins)
    route = route_segments([[x, 0.0] for x in np.arange(-200.0, 5000.0, 200.0)])
    rng = np.random.default_rng(12)
    with_route = without = initial(params, 0, [0.0, 0.0], 3.0, 0.0, [25.0, 0.0])
    for k in range(1, 151):
        m = NavMeasurement(k * NS, ins=ins.increment(25.0, 0.0, 1.0, rng) + (1.0,))
        with_route = nav_update(params, with_route, m, route)
        without = nav_update(params, without, m, ())
    assert abs(without.mean[1]) > 100.0  # dead reckoning: about 25 * 0.003 * 150^2 / 2 = 840 m off
    assert abs(with_route.mean[1]) < 3.0 * params.map_across_std_m
    _, cov = position(with_route)
    assert cov[1, 1] < cov[0, 0]  # across the route known, along it not


def test_off_route_mode_takes_over_when_the_vehicle_leaves_the_route() -> None:
    params = NavParams()
    route = route_segments([[x, 0.0] for x in np.arange(-1000.0, 1000.0, 100.0)])
    estimate = initial(params, 0, [0.0, 0.0], 3.0, math.pi / 2, [0.0, 25.0])  # heading north, across the route
    rng = np.random.default_rng(4)
    for k in range(1, 6):
        truth = np.array([0.0, 25.0 * k])
        m = NavMeasurement(k * NS, ins=(25.0, 0.0, 1.0), gps_xy=truth + rng.normal(size=2) * 3.0, gps_std_m=3.0)
        estimate = nav_update(params, estimate, m, route)
    assert estimate.probabilities[OFF_ROUTE] > 0.9
    assert np.hypot(*(estimate.mean[:2] - truth)) < 10.0


def test_candidates_transitions_and_map_covariance() -> None:
    route = route_segments([[0.0, 0.0], [100.0, 0.0], [100.0, 0.0], [200.0, 100.0], [300.0, 100.0]])
    assert [s.key for s in route] == [0, 2, 3]  # the repeated point's key is skipped, not reused
    assert [s.key for s in candidate_segments(route, [150.0, 20.0], 60.0, 4)] == [0, 2]
    assert [s.key for s in candidate_segments(route, [150.0, 20.0], 60.0, 1)] == [2]
    c = transition_matrix((OFF_ROUTE, 0, 2), (OFF_ROUTE, 2, 3), TransitionModel(leave_route=0.1, jump=0.0))
    np.testing.assert_allclose(c.sum(axis=1), 1.0)
    np.testing.assert_allclose(c[1], [0.1, 0.45, 0.45])  # from 0, neither 0 nor 1 a candidate: shared equally
    assert c[2, 1] == pytest.approx(0.45) and c[2, 2] == pytest.approx(0.45)  # stay or advance
    assert c[1, 0] == pytest.approx(0.1)
    np.testing.assert_allclose(transition_matrix((0, 2), (OFF_ROUTE,), TransitionModel()), [[1.0], [1.0]])
    segment = RouteSegment(0, (0.0, 0.0), (100.0, 100.0))
    obs = map_observation(segment, [60.0, 40.0], along_std_m=30.0, across_std_m=5.0, heading_std_rad=0.1)
    np.testing.assert_allclose(obs.z, [50.0, 50.0, math.pi / 4])
    u, n = np.array([1.0, 1.0]) / math.sqrt(2), np.array([-1.0, 1.0]) / math.sqrt(2)
    assert u @ obs.r[:2, :2] @ u == pytest.approx(900.0) and n @ obs.r[:2, :2] @ n == pytest.approx(25.0)
    assert obs.r[0, 1] == pytest.approx(0.5 * (900.0 - 25.0))  # eq. (3)'s Q_xy for a 45 deg segment
    placed = map_observation(segment, [60.0, 40.0], 30.0, 5.0, 0.1, placement_cov=np.diag([4.0, 9.0, 0.01]))
    np.testing.assert_allclose(placed.r - obs.r, np.diag([4.0, 9.0, 0.01]))  # a route known only so well


def test_nav_measurement_from_a_report() -> None:
    frame = LocalFrame(48.0, 11.0, 500.0)
    lat, lon, _ = frame.to_geodetic(np.array([1200.0, -300.0, 150.0]))
    fix = GpsFix(lat_deg=float(lat), lon_deg=float(lon), alt_m=650.0, fix_type=3, h_acc_m=2.5, v_acc_m=4.0)
    report = NavReport(vehicle_id="uav1", seq=1, stamp_ns=5 * NS, gps=fix,
                       ins=InsIncrement(dt_s=0.2, distance_m=5.0, heading_change_rad=0.01),
                       velocity_enu_mps=(25.0, 1.0, 0.0), heading_rad=0.04)
    m = nav_measurement(report, frame)
    np.testing.assert_allclose(m.gps_xy, [1200.0, -300.0], atol=1e-6)
    assert m.gps_std_m == 2.5 and m.ins == (5.0, 0.01, 0.2) and m.heading_rad == 0.04
    no_fix = nav_measurement(NavReport(vehicle_id="uav1", seq=2, stamp_ns=6 * NS,
                                       gps=GpsFix(lat_deg=float(lat), lon_deg=float(lon), alt_m=650.0, fix_type=1,
                                                  h_acc_m=2.5, v_acc_m=4.0),
                                       ins=report.ins, heading_rad=0.05), frame)
    assert no_fix.gps_xy is None and no_fix.heading_rad is None  # dead-reckoned heading is not a measurement


def test_a_gap_before_the_ins_interval_is_predicted_and_positions_extrapolate() -> None:
    params = NavParams()
    start = initial(params, 0, [0.0, 0.0], 3.0, 0.0, [25.0, 0.0])
    # A lost report: 2 s since the estimate, increments over the last 1 s only.
    later = nav_update(params, start, NavMeasurement(2 * NS, ins=(25.0, 0.0, 1.0)))
    assert later.mean[0] == pytest.approx(50.0)
    xy, cov = position_at(params, later, 2 * NS + NS // 5)
    assert xy[0] == pytest.approx(55.0) and cov[0, 0] > position(later)[1][0, 0]
    np.testing.assert_array_equal(position_at(params, later, NS)[0], position(later)[0])


def test_out_of_order_measurements_are_refused() -> None:
    params = NavParams()
    estimate = initial(params, 5 * NS, [0.0, 0.0], 3.0, 0.0)
    with pytest.raises(ValueError, match="older"):
        nav_update(params, estimate, NavMeasurement(4 * NS, ins=(1.0, 0.0, 1.0)))


def test_the_one_gaussian_update_is_the_routeless_skf() -> None:
    """Without a route GPB2 has one mode: gaussian_update must give nav_update's estimate (to rounding)."""
    from gcs.core.navigation.skf import NavGaussian, gaussian_update

    rng = np.random.default_rng(11)
    params = NavParams()
    xy, heading = _circle(0.0)
    mixture = initial(params, 0, xy, 2.0, heading, 25.0 * np.array([math.cos(heading), math.sin(heading)]))
    single = NavGaussian(mixture.stamp_ns, mixture.mean, mixture.cov)
    for k in range(1, 60):
        t = 0.2 * k
        xy, heading = _circle(t)
        fix = k < 20 or k > 40  # a GPS outage in the middle: INS alone
        measurement = NavMeasurement(round(t * 1e9), ins=(5.0 + rng.normal(0, 0.1), 0.01 + rng.normal(0, 1e-3), 0.2),
                                     gps_xy=xy + rng.normal(0, 2.0, 2) if fix else None, gps_std_m=2.0 if fix else None,
                                     heading_rad=heading if fix else None)
        mixture = nav_update(params, mixture, measurement)
        single = gaussian_update(params, single, measurement)
        assert single.stamp_ns == mixture.stamp_ns
        assert np.allclose(single.mean, mixture.mean, rtol=0, atol=1e-9)
        assert np.allclose(single.cov, mixture.cov, rtol=1e-9, atol=1e-12)
    assert single.cov[0, 0] > 0.0
