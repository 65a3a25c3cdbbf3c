"""The vehicles' INS/odometry: noisy distance and heading-change increments (feng2019 eq. 1).

feng2019 section 1.1 dead-reckons the vehicle's horizontal pose from the INS
increments, eq. (1):

.. math::

    x_{k+1} = x_k + \\delta_s \\cos(\\theta_k + \\delta_\\theta / 2), \\quad
    y_{k+1} = y_k + \\delta_s \\sin(\\theta_k + \\delta_\\theta / 2), \\quad
    \\theta_{k+1} = \\theta_k + \\delta_\\theta,

where ``delta_s`` is the arc length flown over the interval and ``delta_theta``
the heading increment, both supplied by the INS (the paper typesets the
half-angle as ``delta / 2``). This module produces those two increments from
the true ones, with the errors that make dead reckoning drift:

.. math::

    \\tilde\\delta_s = \\max\\bigl(0,\\ \\delta_s (1 + \\epsilon_s) + n_s\\bigr),
    \\qquad n_s \\sim N(0, \\sigma_s^2\\, dt),

    \\tilde\\delta_\\theta = \\delta_\\theta + \\dot\\beta\\, dt + n_\\theta,
    \\qquad n_\\theta \\sim N(0, \\sigma_\\theta^2\\, dt),

with ``epsilon_s = distance_scale_error``, ``beta_dot = heading_drift_rad_s``
(a constant gyro drift). The white-noise terms are random walks:
``distance_std_m`` and ``heading_std_rad`` are the standard deviations accumulated
over ONE SECOND (units m/sqrt(s) and rad/sqrt(s)), so the variance of an
increment grows linearly with its interval ``dt`` and splitting an interval in
two gives the same total error statistics (apart from the clip at zero, which
only matters when the noise is comparable to the distance flown).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gcs.config.simulation import InsConfig

__all__ = ["InsModel"]


@dataclass(frozen=True)
class InsModel:
    """INS truth model: distance scale error and noise, constant heading drift and noise."""

    config: InsConfig

    def increment(self, true_distance_m: float, true_heading_change_rad: float, dt_s: float,
                  rng: np.random.Generator) -> tuple[float, float]:
        """Measured ``(distance_m, heading_change_rad)`` over an interval of ``dt_s`` seconds.

        Parameters
        ----------
        true_distance_m : float
            Distance actually flown (>= 0), metres (``delta_s`` of feng2019 eq. 1).
        true_heading_change_rad : float
            Actual heading change, counter-clockwise positive, radians (``delta_theta``).
        dt_s : float
            Interval length (>= 0), seconds.
        rng : numpy.random.Generator
            Two standard normals are drawn per call, always.

        Returns
        -------
        tuple of float
            Distance (clipped at 0) and heading change (not wrapped), as in the module docstring.
        """
        if not dt_s >= 0.0:
            raise ValueError(f"dt_s must be >= 0, got {dt_s}")
        c = self.config
        root_dt = math.sqrt(dt_s)
        n_s, n_theta = rng.standard_normal(2)
        distance = true_distance_m * (1.0 + c.distance_scale_error) + c.distance_std_m * root_dt * n_s
        heading = true_heading_change_rad + c.heading_drift_rad_s * dt_s + c.heading_std_rad * root_dt * n_theta
        return max(0.0, float(distance)), float(heading)
