"""feng2019's switching Kalman filter for a vehicle's own position: INS, GPS and route matching, centralised.

One call of :func:`nav_update` per navigation report (the daemon's per-vehicle
filter, the ``gcs-bench skf`` experiment):

1. each mode's posterior is predicted by the INS increments, eq. (1) (or, with
   none, by eq. (6)'s constant-velocity model);
2. the candidate route segments near the predicted position become the new
   modes, with the off-route mode (:mod:`gcs.core.navigation.route`); the
   transition matrix maps the previous modes to them;
3. every pair (previous mode i, new mode j) is updated with the observations of
   mode j, stacked (the *centralised* fusion, CF): the GPS fix, eq. (4)-(5),
   when there is one; the map observation of segment j, eq. (2)-(3), unless j is
   off-route; the GNSS velocity and heading when given;
4. GPB2 weighs and collapses the pairs (:func:`gcs.core.filters.switching.gpb2_step`),
   and the whole mixture is collapsed into one Gaussian by moment matching.

The filter holds parameters (:class:`NavParams`); the estimate
(:class:`NavEstimate`) goes in and a new one comes out. Everything is pure.

Use (one estimate per vehicle)::

    params = NavParams.from_scenario(scenario)
    m = nav_measurement(nav_report, frame)                     # LocalFrame of the scenario's origin
    estimate = initial(params, m.stamp_ns, m.gps_xy, m.gps_std_m, heading_rad, m.velocity_xy)  # first fix
    estimate = nav_update(params, estimate, m, route_segments(path_xy), plan_time_estimate.cov[:3, :3])  # every report
    xy, cov = position_at(params, estimate, sensor_report.stamp_ns)  # -> Detection(..., vehicle_cov=cov)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.filters.kalman import Observation, kalman_update, stack_observations
from gcs.core.filters.switching import ModeMixture, gpb2_step
from gcs.core.geometry import LocalFrame, wrap_angle
from gcs.core.navigation.model import (ANGLE_INDICES, STATE_DIM, THETA, X, Y, InsNoise, ScenarioWithIns, cv_predict,
                                       gps_observation, heading_observation, ins_predict, velocity_observation)
from gcs.core.navigation.route import (OFF_ROUTE, RouteSegment, TransitionModel, candidate_segments, map_observation,
                                       transition_matrix)
from protocols.messages import NavReport

__all__ = ["NavParams", "NavMeasurement", "NavEstimate", "NavGaussian", "nav_measurement", "initial", "from_gaussian",
           "predict_modes", "predict_gaussian", "nav_update", "gaussian_update", "nav_measurements", "position",
           "position_at"]

NS_PER_S = 1_000_000_000
MIN_GPS_FIX = 2
"""Lowest MAVLink ``fix_type`` used as a position (2D fix)."""
GAP_TOLERANCE_S = 1e-3
"""Time between the estimate and the start of a report's INS interval below which nothing is predicted."""


@dataclass(frozen=True)
class NavParams:
    """Parameters of the navigation filter (no estimate).

    Attributes
    ----------
    ins : InsNoise
        The INS increments' errors as the filter assumes them.
    transitions : TransitionModel
        Mode transition probabilities.
    map_across_std_m, map_heading_std_rad : float
        ``delta_x`` (across the segment) and ``delta_theta`` of eq. (3).
    map_along_std_m : float or None
        ``delta_y`` of eq. (3); None: each segment's own length.
    candidate_radius_m, max_candidates
        Segments within this distance of the predicted position, at most this many, are modes.
    gps_min_std_m : float
        Floor of the GPS standard deviation per axis (eq. 4 is ``h_acc^2 I``), m.
    velocity_std_mps, heading_std_rad : float
        Errors of a reported GNSS velocity and heading.
    accel_psd_m2_s3, turn_psd_rad2_s3 : float
        Process noise of eq. (6) when a report has no INS increments.
    initial_heading_std_rad, initial_velocity_std_mps, initial_turn_std_rad_s : float
        Prior spread of :func:`initial` beyond the position's.
    """

    ins: InsNoise = InsNoise()
    transitions: TransitionModel = TransitionModel()
    map_across_std_m: float = 10.0
    map_along_std_m: float | None = None
    map_heading_std_rad: float = 0.1
    candidate_radius_m: float = 100.0
    max_candidates: int = 4
    gps_min_std_m: float = 0.5
    velocity_std_mps: float = 0.5
    heading_std_rad: float = 0.05
    accel_psd_m2_s3: float = 4.0
    turn_psd_rad2_s3: float = 1e-3
    initial_heading_std_rad: float = 0.1
    initial_velocity_std_mps: float = 5.0
    initial_turn_std_rad_s: float = 0.05

    def __post_init__(self) -> None:
        for name in ("map_across_std_m", "map_heading_std_rad", "candidate_radius_m", "gps_min_std_m",
                     "velocity_std_mps", "heading_std_rad", "initial_heading_std_rad",
                     "initial_velocity_std_mps", "initial_turn_std_rad_s"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be > 0")
        if self.max_candidates < 0:
            raise ValueError("max_candidates must be >= 0")

    @classmethod
    def from_scenario(cls, scenario: ScenarioWithIns) -> NavParams:
        """Parameters for a scenario's vehicles: the INS figures of ``[simulation.ins]`` as its datasheet.

        The truth's scale error and gyro drift become the filter's allowances for them
        (at least 0.1% and 1e-4 rad/s).
        """
        ins = scenario.simulation.ins
        return cls(ins=InsNoise(distance_std_m=max(ins.distance_std_m, 1e-3),
                                distance_scale_std=max(abs(ins.distance_scale_error), 1e-3),
                                heading_std_rad=max(ins.heading_std_rad, 1e-5),
                                heading_drift_std_rad_s=max(abs(ins.heading_drift_rad_s), 1e-4)))


@dataclass(frozen=True)
class NavMeasurement:
    """What one navigation report says, in ENU (see :func:`nav_measurement`).

    ``ins`` is ``(distance_m, heading_change_rad, dt_s)`` over the interval ending
    at ``stamp_ns``; ``gps_xy`` (2,) with ``gps_std_m`` per axis; ``velocity_xy`` (2,);
    ``heading_rad``. Any may be None.
    """

    stamp_ns: int
    ins: tuple[float, float, float] | None = None
    gps_xy: NDArray[np.float64] | None = None
    gps_std_m: float | None = None
    velocity_xy: NDArray[np.float64] | None = None
    heading_rad: float | None = None

    def __post_init__(self) -> None:
        if (self.gps_xy is None) != (self.gps_std_m is None):
            raise ValueError("gps_xy and gps_std_m go together")

    @property
    def gps_fix(self) -> tuple[NDArray[np.float64], float] | None:
        """``(gps_xy, gps_std_m)``, or None without a fix."""
        if self.gps_xy is None or self.gps_std_m is None:
            return None
        return self.gps_xy, self.gps_std_m


def nav_measurement(report: NavReport, frame: LocalFrame) -> NavMeasurement:
    """The filter's view of a :class:`~protocols.messages.NavReport`.

    The fix is used when ``fix_type >= 2``, with ``h_acc_m`` as its standard deviation
    per axis. The heading is used only alongside a fix: without one, a vehicle's
    reported heading is its own dead reckoning from the same INS increments, and
    using it would count them twice.
    """
    return nav_measurements([report], frame)[0]


def nav_measurements(reports: Sequence[NavReport], frame: LocalFrame) -> list[NavMeasurement]:
    """:func:`nav_measurement` of each report, the fixes converted to ENU in one call
    (:meth:`LocalFrame.to_enu_each`: a report's result does not depend on the others)."""
    fixes = {i: r.gps for i, r in enumerate(reports) if r.gps is not None and r.gps.fix_type >= MIN_GPS_FIX}
    enu = np.zeros((0, 3))
    if fixes:
        enu = frame.to_enu_each(np.array([fix.lat_deg for fix in fixes.values()]),
                                np.array([fix.lon_deg for fix in fixes.values()]),
                                np.array([fix.alt_m for fix in fixes.values()]))
    positions = dict(zip(fixes, range(len(fixes))))
    out = []
    for i, report in enumerate(reports):
        gps_xy: NDArray[np.float64] | None = None
        gps_std: float | None = None
        heading: float | None = None
        fix = fixes.get(i)
        if fix is not None:
            gps_xy, gps_std = enu[positions[i], :2].copy(), float(fix.h_acc_m)
            heading = report.heading_rad
        ins = None
        if report.ins is not None:
            ins = (float(report.ins.distance_m), float(report.ins.heading_change_rad), float(report.ins.dt_s))
        velocity = None if report.velocity_enu_mps is None else np.asarray(report.velocity_enu_mps[:2],
                                                                             dtype=np.float64)
        out.append(NavMeasurement(report.stamp_ns, ins, gps_xy, gps_std, velocity, heading))
    return out


@dataclass(frozen=True)
class NavEstimate:
    """The navigation filter's estimate at ``stamp_ns``.

    ``keys[j]`` names mode j (a segment key, or :data:`~gcs.core.navigation.route.OFF_ROUTE`);
    ``mixture`` holds the mode probabilities and per-mode Gaussians; ``mean`` (6,) and
    ``cov`` (6, 6) are their moment-matched collapse.
    """

    stamp_ns: int
    keys: tuple[int, ...]
    mixture: ModeMixture
    mean: NDArray[np.float64] = field(init=False)
    cov: NDArray[np.float64] = field(init=False)

    def __post_init__(self) -> None:
        assert len(self.keys) == self.mixture.modes, "one key per mode"
        assert self.mixture.means.shape[1] == STATE_DIM
        mean, cov = self.mixture.collapse(ANGLE_INDICES)
        object.__setattr__(self, "mean", mean)
        object.__setattr__(self, "cov", cov)

    @property
    def probabilities(self) -> dict[int, float]:
        """Mode key -> probability."""
        return {k: float(p) for k, p in zip(self.keys, self.mixture.probabilities)}


def initial(params: NavParams, stamp_ns: int, position_xy: ArrayLike, position_std_m: float, heading_rad: float,
            velocity_xy: ArrayLike | None = None) -> NavEstimate:
    """A one-mode (off-route) estimate: position, heading and velocity (along the heading at zero speed if None)."""
    xy = np.asarray(position_xy, dtype=np.float64)
    v = np.zeros(2) if velocity_xy is None else np.asarray(velocity_xy, dtype=np.float64)
    mean = np.array([xy[0], xy[1], wrap_angle(heading_rad), v[0], v[1], 0.0])
    std = np.array([position_std_m, position_std_m, params.initial_heading_std_rad, params.initial_velocity_std_mps,
                    params.initial_velocity_std_mps, params.initial_turn_std_rad_s])
    return from_gaussian(stamp_ns, mean, np.diag(std**2))


def from_gaussian(stamp_ns: int, mean: ArrayLike, cov: ArrayLike) -> NavEstimate:
    """A one-mode (off-route) estimate ``N(mean, cov)``: (6,), (6, 6)."""
    m, c = np.asarray(mean, dtype=np.float64), np.asarray(cov, dtype=np.float64)
    assert m.shape == (STATE_DIM,) and c.shape == (STATE_DIM, STATE_DIM), f"shapes {m.shape}, {c.shape}"
    return NavEstimate(stamp_ns, (OFF_ROUTE,), ModeMixture(np.ones(1), m[None].copy(), c[None].copy()))


def predict_gaussian(params: NavParams, stamp_ns: int, mean: NDArray[np.float64], cov: NDArray[np.float64],
                     measurement: NavMeasurement, process_scale: float = 1.0
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One Gaussian ``N(mean, cov)`` at ``stamp_ns`` predicted to the measurement's time: (6,), (6, 6).

    The INS increments by eq. (1); the part of the interval they do not cover (a lost report,
    the first one) by eq. (6). Raises ValueError for a measurement older than ``stamp_ns``.
    """
    if measurement.stamp_ns < stamp_ns:
        raise ValueError(f"nav measurement at {measurement.stamp_ns} ns is older than the estimate ({stamp_ns} ns)")
    dt = (measurement.stamp_ns - stamp_ns) / NS_PER_S
    gap = dt - measurement.ins[2] if measurement.ins is not None else dt
    if gap > GAP_TOLERANCE_S:
        mean, cov = cv_predict(mean, cov, gap, params.accel_psd_m2_s3, params.turn_psd_rad2_s3, process_scale)
    if measurement.ins is not None:
        distance, turn, ins_dt = measurement.ins
        mean, cov = ins_predict(mean, cov, distance, turn, ins_dt, params.ins, process_scale)
    return mean, cov


def predict_modes(params: NavParams, estimate: NavEstimate, measurement: NavMeasurement,
                  process_scale: float = 1.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Every mode's prediction to the measurement's time (:func:`predict_gaussian`): means (N, 6), covariances (N, 6, 6)."""
    means, covs = estimate.mixture.means.copy(), estimate.mixture.covs.copy()
    for i in range(estimate.mixture.modes):
        means[i], covs[i] = predict_gaussian(params, estimate.stamp_ns, means[i], covs[i], measurement, process_scale)
    return means, covs


def common_observations(params: NavParams, measurement: NavMeasurement, use_gps: bool = True) -> list[Observation]:
    """The observations every mode shares: GPS (eq. 4-5), velocity, heading."""
    observations = []
    fix = measurement.gps_fix
    if use_gps and fix is not None:
        std = max(float(fix[1]), params.gps_min_std_m)
        observations.append(gps_observation(fix[0], np.eye(2) * std**2))
    if use_gps and measurement.velocity_xy is not None:
        observations.append(velocity_observation(measurement.velocity_xy, params.velocity_std_mps))
    if use_gps and measurement.heading_rad is not None:
        observations.append(heading_observation(measurement.heading_rad, params.heading_std_rad))
    return observations


def off_route_log_density(params: NavParams, candidates: Sequence[RouteSegment]) -> float:
    """Log-density the off-route mode gives the map data: uniform across the candidate corridor
    (width ``2 r``) and in heading, and along-track as a segment would (``delta_y`` of eq. 3)."""
    along = params.map_along_std_m or float(np.median([s.length_m for s in candidates]))
    return -math.log(2.0 * params.candidate_radius_m) - math.log(2.0 * math.pi) - 0.5 * math.log(2.0 * math.pi * along**2)


def switch_update(params: NavParams, estimate: NavEstimate, measurement: NavMeasurement,
                  route: Sequence[RouteSegment], shared: Sequence[Observation],
                  process_scale: float = 1.0, route_cov: NDArray[np.float64] | None = None) -> NavEstimate:
    """Steps 1-4 of the module docstring with the given shared observations (all of CF, or one local filter's)."""
    means, covs = predict_modes(params, estimate, measurement, process_scale)
    predicted_xy = estimate.mixture.probabilities @ means[:, :2]
    candidates = candidate_segments(route, predicted_xy, params.candidate_radius_m, params.max_candidates)
    keys = (OFF_ROUTE,) + tuple(s.key for s in candidates)
    transition = transition_matrix(estimate.keys, keys, params.transitions)
    off_density = off_route_log_density(params, candidates) if candidates else 0.0

    def filter_pair(i: int, j: int, _mean: NDArray[np.float64],
                    _cov: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        mean, cov = means[i], covs[i]
        observations = list(shared)
        if j > 0:
            segment = candidates[j - 1]
            along = params.map_along_std_m or segment.length_m
            observations.append(map_observation(segment, mean[:2], along, params.map_across_std_m,
                                                params.map_heading_std_rad, route_cov))
        stacked = stack_observations(observations)
        extra = off_density if j == 0 else 0.0
        if stacked is None:
            return mean, cov, extra
        new_mean, new_cov, log_lik = kalman_update(mean, cov, stacked)
        new_mean[THETA] = wrap_angle(new_mean[THETA])
        return new_mean, new_cov, log_lik + extra

    mixture, _ = gpb2_step(estimate.mixture, transition, filter_pair, ANGLE_INDICES)
    return NavEstimate(measurement.stamp_ns, keys, mixture)


def nav_update(params: NavParams, estimate: NavEstimate, measurement: NavMeasurement,
               route: Sequence[RouteSegment] = (), route_cov: NDArray[np.float64] | None = None) -> NavEstimate:
    """One centralised SKF step (module docstring): INS prediction, then GPS, map and GNSS velocity/heading.

    ``route`` holds the candidate segments' source (e.g. the vehicle's recent commanded
    path, :func:`~gcs.core.navigation.route.route_segments`); empty: no map observations.
    ``route_cov`` (3, 3) is the uncertainty of the route's placement in ``(x, y, theta)``:
    for a commanded path laid out from the vehicle's estimate, that estimate's
    ``cov[:3, :3]`` when the path was planned. Such a path says how far the vehicle moved,
    not where it is: even with ``route_cov`` every update takes it for new information
    and the covariance shrinks below the true error (in a straight-line check without GPS,
    a 4 m standard deviation against a 66 m error after two minutes). A route laid out afresh at every plan restarts its keys, so give the
    filter ``TransitionModel(stay=1, advance=1, jump=1)``: no topology between plans.
    Raises ValueError for a measurement older than the estimate.
    """
    return switch_update(params, estimate, measurement, route, common_observations(params, measurement),
                         route_cov=route_cov)


@dataclass(frozen=True)
class NavGaussian:
    """A one-Gaussian estimate at ``stamp_ns``: ``mean`` (6,), ``cov`` (6, 6) (what :func:`gaussian_update` carries)."""

    stamp_ns: int
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]


def gaussian_update(params: NavParams, estimate: NavGaussian, measurement: NavMeasurement) -> NavGaussian:
    """:func:`nav_update` without a route, on one Gaussian: predicted by :func:`predict_gaussian`, then the
    stacked GPS (eq. 4-5), GNSS velocity and heading in one Kalman update.

    Without route segments the only mode is off-route, and GPB2 with one mode is this
    extended Kalman filter; this form skips the mixture's bookkeeping (about a third of
    the time per report). Raises ValueError for a measurement older than the estimate.
    """
    mean, cov = predict_gaussian(params, estimate.stamp_ns, estimate.mean, estimate.cov, measurement)
    stacked = stack_observations(common_observations(params, measurement))
    if stacked is not None:
        mean, cov, _ = kalman_update(mean, cov, stacked)
        mean[THETA] = wrap_angle(mean[THETA])
    return NavGaussian(measurement.stamp_ns, mean, cov)


def position(estimate: NavEstimate | NavGaussian) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The collapsed horizontal position (2,), ENU metres, and its covariance (2, 2), m^2."""
    return estimate.mean[[X, Y]].copy(), estimate.cov[np.ix_((X, Y), (X, Y))].copy()


def position_at(params: NavParams, estimate: NavEstimate | NavGaussian,
                stamp_ns: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`position` extrapolated to ``stamp_ns`` by eq. (6) (e.g. a sensor report between two nav reports).

    The estimate is not changed; a stamp at or before the estimate's gives :func:`position` itself.
    """
    dt = (stamp_ns - estimate.stamp_ns) / NS_PER_S
    if dt <= 0.0:
        return position(estimate)
    mean, cov = cv_predict(estimate.mean, estimate.cov, dt, params.accel_psd_m2_s3, params.turn_psd_rad2_s3)
    return mean[[X, Y]].copy(), cov[np.ix_((X, Y), (X, Y))].copy()

