"""Posterior Cramer-Rao lower bound (PCRLB) by the Tichavsky recursion.

Tichavsky, Muravchik and Nehorai (1998) give, for ``x[k+1] = F x[k] + q``,
``q ~ N(0, Q)`` and measurements ``z = h(x) + r``, ``r ~ N(0, R)``, the
Fisher information recursion

.. math::
    J_{k+1} = D^{22}_k - D^{21}_k (J_k + D^{11}_k)^{-1} D^{12}_k

with ``D11 = F^T Q^-1 F``, ``D12 = (D21)^T = -F^T Q^-1`` and
``D22 = Q^-1 + E[H^T R^-1 H]``, ``H`` the Jacobian of ``h`` at the true
state. By the matrix inversion lemma this is

.. math::
    J_{k+1} = (Q + F J_k^{-1} F^T)^{-1} + E\\Big[\\sum_v d_v H_v^T R_v^{-1} H_v\\Big]

which is what is computed (it also holds for a singular ``Q``). ``d_v`` is 1
when vehicle v detects the target at that step and 0 otherwise, so occlusion
and range limits enter through the detection pattern. The expectation over
the target's random trajectory is the average over the supplied sample
trajectories (one trajectory gives the bound conditional on it).

``J_k^-1`` bounds the covariance of any unbiased estimator; ``sqrt(tr)`` of its
position block is the floor under the position RMSE. Distance-dependent
noise (zuo2021) adds a term for ``dR/dx``: that generalised bound lives with
the zuo2021 estimator, not here.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.motion import LinearMotionModel
from gcs.core.models.sensor import SensorModel

__all__ = ["information_recursion", "measurement_information", "pcrlb"]


def measurement_information(
    sensors: Sequence[SensorModel],
    vehicle_xyz: NDArray[np.float64],
    detected: NDArray[np.bool_],
    target_states: NDArray[np.float64],
    state_dim: int,
) -> NDArray[np.float64]:
    """``E[sum_v d_v H_v^T R_v^-1 H_v]`` at each step.

    Parameters
    ----------
    sensors : sequence of SensorModel, length V
    vehicle_xyz : ndarray, shape (K, V, 3) or (S, K, V, 3)
    detected : ndarray of bool, shape (K, V) or (S, K, V)
    target_states : ndarray, shape (K, n) or (S, K, n)
        True target states; a leading sample axis S averages over trajectories.

    Returns
    -------
    ndarray, shape (K, state_dim, state_dim)
    """
    states = np.asarray(target_states, dtype=np.float64)
    if states.ndim == 2:
        states = states[None]
    vehicles = np.broadcast_to(np.asarray(vehicle_xyz, dtype=np.float64), states.shape[:2] + np.shape(vehicle_xyz)[-2:])
    seen = np.broadcast_to(np.asarray(detected, dtype=bool), vehicles.shape[:-1])
    if len(sensors) != vehicles.shape[-2]:
        raise ValueError(f"{len(sensors)} sensors for {vehicles.shape[-2]} vehicles")
    info = np.zeros(states.shape[:2] + (state_dim, state_dim))
    for v, sensor in enumerate(sensors):
        h = sensor.jacobian(states, vehicles[..., v, :], state_dim)  # (S, K, m, n)
        r_inv = sensor.noise_information(None, states, vehicles[..., v, :])
        contribution = h.swapaxes(-1, -2) @ (h * np.asarray(r_inv)[..., None])
        info += np.where(seen[..., v, None, None], contribution, 0.0)
    mean_info: NDArray[np.float64] = info.mean(axis=0)
    return mean_info


def pcrlb(
    motion: LinearMotionModel,
    step_s: float,
    initial_cov: NDArray[np.float64],
    sensors: Sequence[SensorModel],
    vehicle_xyz: NDArray[np.float64],
    detected: NDArray[np.bool_],
    target_states: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Bound ``J_k^-1`` on the estimation error covariance at each of K steps.

    Step 0 is the first measurement time: ``J_0 = P_0^-1 + E[J_z(0)]``, and
    every later step first applies the motion recursion. Arguments as in
    :func:`measurement_information`; ``initial_cov`` is the prior ``P_0``.

    Returns
    -------
    ndarray, shape (K, n, n)
    """
    n = motion.dim
    f, q = motion.matrices(step_s)
    j_z = measurement_information(sensors, vehicle_xyz, detected, target_states, n)
    return information_recursion(f, q, np.linalg.inv(initial_cov).astype(np.float64, copy=False), j_z)


def information_recursion(f: NDArray[np.float64], q: NDArray[np.float64], initial_information: NDArray[np.float64],
                          measurement_info: NDArray[np.float64]) -> NDArray[np.float64]:
    """The Tichavsky recursion for linear Gaussian motion: ``J_0 = J_prior + J_z(0)``,
    ``J_{k+1} = (Q + F J_k^{-1} F^T)^{-1} + J_z(k+1)``; returns the bounds ``J_k^{-1}`` (K, n, n).

    ``measurement_info`` (K, n, n) is each step's expected measurement information
    (:func:`measurement_information` here, the generalised information of
    :func:`gcs.core.gcrlb.fisher_information` for zuo2021).
    """
    bounds = np.empty_like(measurement_info)
    information = np.array(initial_information, dtype=np.float64)
    for k in range(measurement_info.shape[0]):
        if k > 0:
            information = np.linalg.inv(q + f @ bounds[k - 1] @ f.T)
        information = information + measurement_info[k]
        bound = np.linalg.inv(information)
        bounds[k] = 0.5 * (bound + bound.T)
    return bounds
