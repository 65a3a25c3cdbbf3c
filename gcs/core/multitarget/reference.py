"""Reference implementation of the multi-target filter: one track at a time, in covariance form.

The oracle that :mod:`gcs.core.multitarget.filter` is tested equal to. It shares
only the sensor model (``h``, its Jacobians, ``R``) with the batched code; the
algebra is the textbook one, written per track:

* one detection per vehicle (GNN): the measurements of every vehicle are stacked
  into one vector and the Kalman update ``K = P H^T (H P H^T + R)^-1``,
  ``x = x^- + K nu``, ``P = P^- - K S K^T`` is applied once, with ``R``
  block-diagonal across vehicles; for a common linearisation point that equals
  the sum of information contributions of wang2012 eq. (14)-(15);
* probabilistic association (PDA/JPDA): for each vehicle the mixture of the prior
  (weight ``beta_0``) and the full-state Kalman updates with each detection is
  reduced to its mean and covariance, then the vehicles' posteriors are fused
  with the common prior counted once (the information sum
  ``Y = sum_v Y_v - (V - 1) Y^-``, ``y = sum_v y_v - (V - 1) y^-``).

Slow by design; not used by the tracker.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.motion import LinearMotionModel
from gcs.core.models.sensor import SensorModel

__all__ = ["VehicleBatch", "reference_predict", "reference_assigned_update", "reference_mixture_update"]

VehicleBatch = tuple[SensorModel, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
"""One vehicle's detections: the sensor, ``z`` (n, m), ``vehicle_xyz`` (n, 3), ``vehicle_cov`` (n, 3, 3)."""


def reference_predict(mean: NDArray[np.float64], cov: NDArray[np.float64], dt_s: float,
                      motion: LinearMotionModel) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``F x``, ``F P F^T + Q`` track by track."""
    f, q = motion.matrices(dt_s)
    means, covs = [], []
    for x, p in zip(mean, cov):
        means.append(f @ x)
        covs.append(f @ p @ f.T + q)
    return np.array(means).reshape(mean.shape), np.array(covs).reshape(cov.shape)


def _linearise(x: NDArray[np.float64], sensor: SensorModel, z: NDArray[np.float64], xyz: NDArray[np.float64],
               pcov: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Innovation (m,), full-state Jacobian (m, 4) and noise (m, m) of one detection for one track."""
    z_pred = sensor.measure(x[:2], xyz)
    h = np.zeros((sensor.dim, 4))
    h[:, :2] = sensor.jacobian(x[:2], xyz)
    j_s = sensor.vehicle_jacobian(x[:2], xyz)
    r = np.diag(np.broadcast_to(sensor.noise_variance(z_pred, x[:2], xyz), (sensor.dim,))) + j_s @ pcov @ j_s.T
    return sensor.residual(z, z_pred), h, r


def reference_assigned_update(mean: NDArray[np.float64], cov: NDArray[np.float64],
                              vehicles: Sequence[VehicleBatch], assigned: Sequence[NDArray[np.int64]]
                              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Every track updated by its assigned detection of each vehicle (``assigned[v][t]``, -1 for none)."""
    means, covs = [], []
    for t, (x, p) in enumerate(zip(mean, cov)):
        nus, hs, rs = [], [], []
        for (sensor, z, xyz, pcov), chosen in zip(vehicles, assigned):
            j = int(chosen[t])
            if j < 0:
                continue
            nu, h, r = _linearise(x, sensor, z[j], xyz[j], pcov[j])
            nus.append(nu)
            hs.append(h)
            rs.append(r)
        if not nus:
            means.append(x.copy())
            covs.append(p.copy())
            continue
        nu, h = np.concatenate(nus), np.vstack(hs)
        r = np.zeros((nu.size, nu.size))
        start = 0
        for block in rs:
            r[start:start + block.shape[0], start:start + block.shape[0]] = block
            start += block.shape[0]
        s = h @ p @ h.T + r
        k = p @ h.T @ np.linalg.inv(s)
        means.append(x + k @ nu)
        covs.append(p - k @ s @ k.T)
    return np.array(means).reshape(mean.shape), np.array(covs).reshape(cov.shape)


def _mixture_posterior(x: NDArray[np.float64], p: NDArray[np.float64], batch: VehicleBatch,
                       beta: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One vehicle's PDA posterior of one track: the moment-matched mixture of the prior and its updates."""
    sensor, z, xyz, pcov = batch
    weights = [1.0 - float(beta.sum())]
    components = [(x, p)]
    for j in range(z.shape[0]):
        nu, h, r = _linearise(x, sensor, z[j], xyz[j], pcov[j])
        s = h @ p @ h.T + r
        k = p @ h.T @ np.linalg.inv(s)
        weights.append(float(beta[j]))
        components.append((x + k @ nu, p - k @ s @ k.T))
    mean = sum((w * m for w, (m, _) in zip(weights, components)), start=np.zeros_like(x))
    cov = sum((w * (c + np.outer(m - mean, m - mean)) for w, (m, c) in zip(weights, components)),
              start=np.zeros_like(p))
    return mean, cov


def reference_mixture_update(mean: NDArray[np.float64], cov: NDArray[np.float64],
                             vehicles: Sequence[VehicleBatch], betas: Sequence[NDArray[np.float64]]
                             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Every track updated by each vehicle's detections with probabilities ``betas[v][t, j]``, then fused."""
    means, covs = [], []
    for t, (x, p) in enumerate(zip(mean, cov)):
        y_prior = np.linalg.inv(p)
        y_total = y_prior.copy()
        v_total = y_prior @ x
        for batch, beta in zip(vehicles, betas):
            xv, pv = _mixture_posterior(x, p, batch, beta[t])
            yv = np.linalg.inv(pv)
            y_total += yv - y_prior
            v_total += yv @ xv - y_prior @ x
        post = np.linalg.inv(y_total)
        means.append(post @ v_total)
        covs.append(post)
    return np.array(means).reshape(mean.shape), np.array(covs).reshape(cov.shape)
