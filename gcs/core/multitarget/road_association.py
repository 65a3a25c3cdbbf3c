"""One vehicle's detections against every road track's particles: association scores and the weight update.

Monte Carlo JPDA (Schulz, Burgard, Fox and Cremers 2003; Vermaak, Godsill and
Pérez 2005) with a detection probability that depends on where the target is
(Koch 2007, negative information). Track ``t`` is a cloud of particles ``x_ti``
with weights ``w_ti`` (:mod:`gcs.core.multitarget.road_clouds`). Vehicle ``v``
detects a target at ``x`` with probability

.. math::
    P_D(x) = P_D \\big(\\kappa + (1 - \\kappa)\\, c_v(x)\\big)

where ``c_v(x)`` is 1 when ``x`` is in ``v``'s field and in sight past the
buildings (the world's sight table, :func:`gcs.core.roads.sensing.table_sees`)
and ``kappa`` keeps a floor for the table's approximations. With ``l_tij`` the
likelihood of detection ``j`` at particle ``i`` (:func:`gcs.core.roads.sensing.detection_log_likelihoods`,
the hypothesis' road spread added to the noise), the track-level terms of the
JPDA's joint events (Bar-Shalom, Willett and Tian 2011, the parametric JPDA) are
the particle averages

.. math::
    a_{tj} = \\sum_i w_{ti} P_D(x_{ti})\\, l_{tij}, \\qquad
    m_t = \\sum_i w_{ti} \\big(1 - P_D(x_{ti}) P_G\\big),

so the cost of pairing ``t`` with ``j`` against "``t`` missed, ``j`` clutter" is
``c_tj = -ln(a_tj / (lambda m_t))``, which is :func:`gcs.core.multitarget.gnn.assignment_costs`
with the Gaussian likelihood replaced by the cloud's. GNN and JPDA give the
association probabilities ``beta_tj`` from these costs as for the Gaussian tracks.

**Update.** The posterior of track ``t`` is the mixture over its association
hypotheses, each hypothesis' posterior normalised:

.. math::
    w'_{ti} = \\beta_{t0} \\frac{w_{ti} (1 - P_D(x_{ti}) P_G)}{m_t}
        + \\sum_j \\beta_{tj} \\frac{w_{ti} P_D(x_{ti})\\, l_{tij}}{a_{tj}}

(the PDA's mixture, particle by particle; GNN's ``beta`` is one-hot). The first
term is the negative information: a vehicle that had part of a cloud in sight
and found nothing moves the weight to the part it could not see. A vehicle with
no detections at all updates every track by that term alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.roads.sensing import DetectionGroup, detection_log_likelihoods

__all__ = ["ParticleTerms", "detection_probabilities", "particle_terms", "costs_of", "mixture_log_weights", "log_sum"]


@dataclass(frozen=True, eq=False)
class ParticleTerms:
    """One vehicle's terms for T tracks of P particles and n detections (module docstring).

    ``joint`` (T, P, n): ``ln w_ti P_D(x_ti) l_tij``; ``log_a`` (T, n): ``ln a_tj``;
    ``missed`` (T, P): ``ln w_ti (1 - P_D(x_ti) P_G)``; ``log_m`` (T,): ``ln m_t``.
    """

    joint: NDArray[np.float64]
    log_a: NDArray[np.float64]
    missed: NDArray[np.float64]
    log_m: NDArray[np.float64]


def detection_probabilities(seen: NDArray[np.bool_] | None, shape: tuple[int, ...], detection_probability: float,
                            floor: float) -> NDArray[np.float64]:
    """``P_D(x)`` (module docstring) of particles ``seen`` (bool, ``shape``) by one vehicle; ``P_D`` everywhere
    when ``seen`` is None (no sight test)."""
    if seen is None:
        return np.full(shape, detection_probability)
    return detection_probability * (floor + (1.0 - floor) * np.asarray(seen, dtype=np.float64))


def log_sum(values: NDArray[np.float64], axis: int) -> NDArray[np.float64]:
    """``ln sum exp(values)`` along ``axis``, ``-inf`` where every term is ``-inf`` (no warning, no NaN)."""
    top = np.max(values, axis=axis, keepdims=True)
    safe = np.where(np.isfinite(top), top, 0.0)
    total: NDArray[np.float64] = np.squeeze(safe, axis=axis) + np.log(np.sum(np.exp(values - safe), axis=axis))
    return total


def particle_terms(xy: NDArray[np.float64], log_w: NDArray[np.float64], pd: NDArray[np.float64],
                   gate_probability: float, group: DetectionGroup | None, spread_var_m2: float) -> ParticleTerms:
    """The terms of one vehicle (module docstring) for particles ``xy`` (T, P, 2) with log-weights (T, P) and
    detection probabilities ``pd`` (T, P); ``group`` None for a vehicle that detected nothing."""
    t, p = log_w.shape
    with np.errstate(divide="ignore"):
        missed = log_w + np.log1p(-pd * gate_probability)
        log_pd = np.log(pd)
    if group is None:
        joint = np.zeros((t, p, 0))
    else:
        log_l, _ = detection_log_likelihoods(xy.reshape(-1, 2), group, spread_var_m2)
        joint = (log_w + log_pd)[:, :, None] + log_l.reshape(t, p, -1)
    return ParticleTerms(joint, log_sum(joint, 1), missed, log_sum(missed, 1))


def costs_of(terms: ParticleTerms, valid: NDArray[np.bool_], clutter_density: float) -> NDArray[np.float64]:
    """``c_tj = -ln(a_tj / (lambda m_t))`` (T, n) where ``valid``, ``+inf`` elsewhere."""
    if not clutter_density > 0.0:
        raise ValueError(f"clutter density must be > 0, got {clutter_density!r}")
    with np.errstate(invalid="ignore"):
        cost = np.log(clutter_density) + terms.log_m[:, None] - terms.log_a
    return np.where(valid & np.isfinite(cost), cost, np.inf)


def mixture_log_weights(terms: ParticleTerms, beta: NDArray[np.float64]) -> NDArray[np.float64]:
    """``ln w'_ti`` (T, P) of the update of the module docstring, ``beta`` (T, n) the association probabilities."""
    beta0 = np.clip(1.0 - beta.sum(axis=1), 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        parts = [np.log(beta0)[:, None] + terms.missed - terms.log_m[:, None]]
        if beta.shape[1]:
            shares = terms.joint - terms.log_a[:, None, :]  # ln of each particle's share of a_tj
            weighted = np.where(beta[:, None, :] > 0.0, np.log(beta)[:, None, :] + shares, -np.inf)
            parts.append(log_sum(weighted, 2))
    stacked = np.stack(parts, axis=0)
    out = log_sum(stacked, 0)
    return np.where(np.isnan(out), -np.inf, out)

