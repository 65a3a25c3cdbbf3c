"""A manoeuvring target: IMM of constant velocity and coordinated turn, each mode updated by the DUIF.

feng2019's switching machinery (:mod:`gcs.core.filters.switching`) applied to the
ground target in place of the single-model DUIF of wang2012. Mode state
``[x, y, vx, vy, omega]`` (ENU m, m/s, turn rate rad/s, position first as the
UIF requires):

* mode 0, constant velocity (wang2012 eq. 2): ``F_cv`` on ``[x, y, vx, vy]`` with
  white acceleration of density ``q_cv``; its turn rate is not part of its motion
  and restarts as ``N(0, sigma_omega^2)`` each step (a CV target has no turn to remember);
* mode 1, coordinated turn (Bar-Shalom, Li, Kirubarajan 2001, section 11.7):

.. math::
    x' = x + \\frac{\\sin\\omega T}{\\omega} v_x - \\frac{1 - \\cos\\omega T}{\\omega} v_y, \\quad
    y' = y + \\frac{1 - \\cos\\omega T}{\\omega} v_x + \\frac{\\sin\\omega T}{\\omega} v_y,

    v' = R(\\omega T)\\, v, \\quad \\omega' = \\omega

  predicted by the unscented transform (it is non-linear in ``omega``), with white
  acceleration ``q_ct`` and a turn-rate random walk ``q_omega``.

Each mode is updated with the step's detections exactly as the DUIF does
(:meth:`UnscentedInformationFilter.contribution` / ``update``: eq. 12-15,
vehicle position covariances included), and scored by the likelihood of the
stacked innovations ``N(nu; 0, H^p P H^p^T + R)`` with the same ``H^p``.
The modes are mixed and reweighed by IMM (Blom and Bar-Shalom; row-stochastic
transition matrix, :func:`gcs.core.filters.switching.imm_step`).

The estimate (:class:`ImmEstimate`) *is* a :class:`GaussianEstimate` of the
``cv2d`` layout ``[x, y, vx, vy]`` (the moment-matched collapse of the modes), so
the k+n prediction, the planner and the published track use it unchanged; it
also carries the modes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.switching import ModeMixture, check_transition, imm_step
from gcs.core.filters.uif import NS_PER_S, GaussianEstimate, UnscentedInformationFilter, pseudo_measurement
from gcs.core.filters.unscented import SigmaPointParameters
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import DetectionGroup

__all__ = ["ImmEstimate", "ImmTargetFilter", "MODE_NAMES", "coordinated_turn"]

MODE_NAMES = ("cv", "ct")
STATE_DIM = 5
OMEGA = 4
_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True)
class ImmEstimate(GaussianEstimate):
    """The collapsed ``cv2d`` estimate (``mean`` (4,), ``cov`` (4, 4), ``stamp_ns``) and the modes (5-D each)."""

    modes: ModeMixture = field(kw_only=True)

    @property
    def probabilities(self) -> NDArray[np.float64]:
        """P(constant velocity), P(coordinated turn)."""
        return self.modes.probabilities


def coordinated_turn(states: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
    """The coordinated-turn transition of states (..., 5) over ``dt`` (module docstring), exact as omega -> 0."""
    x, y, vx, vy, w = np.moveaxis(states, -1, 0)
    wt = w * dt
    small = np.abs(wt) < 1e-9
    safe = np.where(small, 1.0, w)
    s = np.where(small, dt, np.sin(wt) / safe)  # sin(wT)/w -> T
    c = np.where(small, 0.5 * w * dt * dt, (1.0 - np.cos(wt)) / safe)  # (1 - cos wT)/w -> w T^2 / 2
    cos, sin = np.cos(wt), np.sin(wt)
    return np.stack([x + s * vx - c * vy, y + c * vx + s * vy, cos * vx - sin * vy, sin * vx + cos * vy, w], axis=-1)


@dataclass(frozen=True)
class ImmTargetFilter:
    """Parameters of the CV + CT IMM (no estimate).

    Attributes
    ----------
    cv_accel_psd_m2_s3, ct_accel_psd_m2_s3 : float
        White acceleration density of each mode.
    turn_psd_rad2_s3 : float
        Random walk of the CT mode's turn rate (rad^2/s^3).
    initial_turn_std_rad_s : float
        Spread of the turn rate when a track starts, and of the CV mode's each step.
    transition : (2, 2) nested tuple
        Row-stochastic ``C[i, j] = P(mode j at k | mode i at k-1)`` per step (CV, CT).
    initial_probabilities : (2,) tuple
    """

    cv_accel_psd_m2_s3: float = 0.05
    ct_accel_psd_m2_s3: float = 2.0
    turn_psd_rad2_s3: float = 0.01
    initial_turn_std_rad_s: float = 0.3
    transition: tuple[tuple[float, float], tuple[float, float]] = ((0.95, 0.05), (0.1, 0.9))
    initial_probabilities: tuple[float, float] = (0.9, 0.1)
    sigma: SigmaPointParameters = SigmaPointParameters()

    def __post_init__(self) -> None:
        check_transition(np.asarray(self.transition), 2, 2)
        p = np.asarray(self.initial_probabilities)
        assert p.shape == (2,) and abs(p.sum() - 1.0) < 1e-9 and np.all(p >= 0), "initial probabilities: (2,), sum 1"

    @property
    def uif(self) -> UnscentedInformationFilter:
        """The DUIF whose measurement update every mode uses (its motion model is not used here)."""
        return UnscentedInformationFilter(constant_velocity(self.cv_accel_psd_m2_s3), self.sigma)

    def start(self, estimate: GaussianEstimate) -> ImmEstimate:
        """Both modes from a ``cv2d`` estimate, the turn rate ``N(0, initial_turn_std^2)``."""
        assert estimate.mean.shape == (4,), "the IMM starts from a cv2d estimate [x, y, vx, vy]"
        mean = np.append(estimate.mean, 0.0)
        cov = np.zeros((STATE_DIM, STATE_DIM))
        cov[:4, :4] = estimate.cov
        cov[OMEGA, OMEGA] = self.initial_turn_std_rad_s**2
        modes = ModeMixture(np.asarray(self.initial_probabilities, dtype=np.float64), np.stack([mean, mean]),
                            np.stack([cov, cov]))
        return _estimate(modes, estimate.stamp_ns)

    def predict_mode(self, mode: int, mean: NDArray[np.float64], cov: NDArray[np.float64],
                     dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Mode ``mode``'s prediction over ``dt`` seconds: (5,), (5, 5)."""
        if dt <= 0.0:
            return mean, cov
        block = np.array([[dt**3 / 3.0, dt**2 / 2.0], [dt**2 / 2.0, dt]])
        q = np.zeros((STATE_DIM, STATE_DIM))
        psd = self.cv_accel_psd_m2_s3 if mode == 0 else self.ct_accel_psd_m2_s3
        for p, v in ((0, 2), (1, 3)):
            q[np.ix_((p, v), (p, v))] = psd * block
        if mode == 0:
            f = np.eye(STATE_DIM)
            f[0, 2] = f[1, 3] = dt
            f[OMEGA, OMEGA] = 0.0
            q[OMEGA, OMEGA] = self.initial_turn_std_rad_s**2
            new_cov = f @ cov @ f.T + q
            return f @ mean, 0.5 * (new_cov + new_cov.T)
        q[OMEGA, OMEGA] = self.turn_psd_rad2_s3 * dt
        wm, wc, _ = self.sigma.weights(STATE_DIM)
        points = coordinated_turn(self.sigma.points(mean, cov), dt)
        new_mean = wm @ points
        d = points - new_mean
        new_cov = (d.T * wc) @ d + q
        return new_mean, 0.5 * (new_cov + new_cov.T)

    def update_mode(self, prior: GaussianEstimate, groups: Sequence[DetectionGroup]) -> tuple[GaussianEstimate, float]:
        """The DUIF update of one mode's prediction and the log-likelihood of the detections under it.

        ``groups``: per sensor model, measurements (k, m), vehicle positions (k, 3), and vehicle covariances
        (k, 3, 3), per-axis variances (k,) or None (as :meth:`UnscentedInformationFilter.contribution` takes).
        """
        if not groups:
            return prior, 0.0
        uif = self.uif
        contributions = [uif.contribution(prior, s, z, xyz, covs) for s, z, xyz, covs in groups]
        posterior = uif.update(prior, contributions)
        h_rows: list[NDArray[np.float64]] = []
        nu: list[NDArray[np.float64]] = []
        r_blocks: list[NDArray[np.float64]] = []
        for sensor, z, xyz, covs in groups:
            z_pred, h_pos = pseudo_measurement(prior, sensor, xyz, self.sigma)
            r = uif.noise_covariance(prior, sensor, z_pred, xyz, covs)  # the R of the mode's update
            h_rows.append(h_pos.reshape(-1, 2))
            nu.append(sensor.residual(z, z_pred).ravel())
            r_blocks.extend(r)
        h, innovation = np.vstack(h_rows), np.concatenate(nu)
        r_all = np.zeros((h.shape[0], h.shape[0]))
        offset = 0
        for block in r_blocks:
            m = block.shape[0]
            r_all[offset:offset + m, offset:offset + m] = block
            offset += m
        s = h @ prior.cov[:2, :2] @ h.T + r_all
        sign, log_det = np.linalg.slogdet(s)
        log_lik = -0.5 * (innovation @ np.linalg.solve(s, innovation) + log_det + innovation.size * _LOG_2PI)
        return posterior, float(log_lik) if sign > 0 else -np.inf

    def step(self, estimate: ImmEstimate, stamp_ns: int,
             groups: Sequence[DetectionGroup]) -> ImmEstimate:
        """One IMM cycle to ``stamp_ns`` with the detections ``groups`` (see :meth:`update_mode`)."""
        if stamp_ns < estimate.stamp_ns:
            raise ValueError(f"cannot predict backwards from {estimate.stamp_ns} ns to {stamp_ns} ns")
        dt = (stamp_ns - estimate.stamp_ns) / NS_PER_S

        def filter_mode(j: int, mean: NDArray[np.float64],
                        cov: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
            m, p = self.predict_mode(j, mean, cov, dt)
            posterior, log_lik = self.update_mode(GaussianEstimate(m, p, stamp_ns), groups)
            return posterior.mean, posterior.cov, log_lik

        transition = np.asarray(self.transition) if dt > 0.0 else np.eye(2)
        return _estimate(imm_step(estimate.modes, transition, filter_mode), stamp_ns)


def _estimate(modes: ModeMixture, stamp_ns: int) -> ImmEstimate:
    mean, cov = modes.collapse()
    return ImmEstimate(mean[:4].copy(), cov[:4, :4].copy(), stamp_ns, modes=modes)
