"""The vehicles' GPS receiver: white noise plus a first-order Gauss-Markov bias, and denied zones.

Per ENU axis ``i`` the reading is

.. math::

    z_i = p_i + b_i + n_i, \\qquad n_i \\sim N(0, \\sigma_{n,i}^2),

with ``sigma_n = horizontal_std_m`` for east and north and ``vertical_std_m``
for up. The bias ``b`` is a first-order Gauss-Markov process of standard
deviation ``sigma_b = bias_std_m`` (every axis, vertical too) and time constant
``tau = bias_time_constant_s``, propagated exactly over any interval ``dt``:

.. math::

    b_{k+1} = \\phi b_k + w_k, \\qquad \\phi = e^{-dt/\\tau},
    \\qquad w_k \\sim N(0, \\sigma_b^2 (1 - \\phi^2)),

so its stationary variance is ``sigma_b^2`` and its lag-``dt`` autocorrelation
``phi`` whatever the step. The receiver reports the total 1-sigma error per
axis, ``sqrt(sigma_n^2 + sigma_b^2)`` (the bias is unknown to it), as MAVLink's
``h_acc``/``v_acc`` do; ``horizontal_std_m`` is the std of ONE horizontal axis,
not the radial error.

Inside a GPS-denied polygon (even-odd rule, horizontal position only) there is
no fix: ``fix_type`` 1 (MAVLink ``GPS_FIX_TYPE_NO_FIX``), no position, no
satellites. The random draws are the same inside and outside, so a denied zone
changes only the readings, never the bias path or the later noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.config.simulation import GpsConfig
from gcs.core.world._polygons import as_ring, bboxes, inside_any, pad_edges

if TYPE_CHECKING:
    from gcs.config import Scenario

__all__ = ["GpsModel", "GpsState", "GpsReading", "FIX_NONE", "FIX_3D"]

FIX_NONE = 1
"""MAVLink ``GPS_FIX_TYPE_NO_FIX``."""
FIX_3D = 3
"""MAVLink ``GPS_FIX_TYPE_3D_FIX``."""


@dataclass(frozen=True, eq=False)
class GpsState:
    """The receiver's hidden state: the current bias (3,), ENU metres."""

    bias_enu_m: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class GpsReading:
    """One GPS output.

    Attributes
    ----------
    position_enu_m : ndarray, shape (3,), or None
        Measured ENU position, metres; None without a fix.
    horizontal_std_m, vertical_std_m : float
        Reported 1-sigma error of one horizontal axis and of the vertical,
        metres: ``sqrt(noise_std^2 + bias_std^2)`` (the nominal accuracy, also
        given without a fix).
    fix_type : int
        :data:`FIX_3D` with a fix, :data:`FIX_NONE` in a denied zone.
    satellites : int
        Satellites used: the configured count, 0 without a fix.
    """

    position_enu_m: NDArray[np.float64] | None
    horizontal_std_m: float
    vertical_std_m: float
    fix_type: int
    satellites: int


@dataclass(frozen=True, eq=False)
class GpsModel:
    """GPS truth model: ``config`` noise and bias, ``denied`` polygons (K_i, 2) in ENU metres."""

    config: GpsConfig
    denied: tuple[NDArray[np.float64], ...] = ()
    _edges: NDArray[np.float64] = field(init=False, repr=False)
    _bbox: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        rings = tuple(as_ring(p, f"GPS-denied polygon {i}") for i, p in enumerate(self.denied))
        edges, _ = pad_edges(rings)
        object.__setattr__(self, "denied", rings)
        object.__setattr__(self, "_edges", edges)
        object.__setattr__(self, "_bbox", bboxes(edges))

    @classmethod
    def from_scenario(cls, scenario: Scenario) -> GpsModel:
        """``scenario.simulation.gps`` with the scenario's ``[[gps_denied]]`` polygons."""
        return cls(scenario.simulation.gps, tuple(np.asarray(z.polygon_enu_m, dtype=np.float64)
                                                  for z in scenario.gps_denied))

    @property
    def noise_std_enu_m(self) -> NDArray[np.float64]:
        """White-noise standard deviation per axis (3,), metres."""
        c = self.config
        return np.array([c.horizontal_std_m, c.horizontal_std_m, c.vertical_std_m])

    def denied_at(self, xy: ArrayLike) -> NDArray[np.bool_]:
        """Whether each horizontal position (..., 2) lies inside a denied polygon."""
        p = np.asarray(xy, dtype=np.float64)
        flat = p.reshape(-1, 2)
        return inside_any(flat[:, 0], flat[:, 1], self._bbox, self._edges).reshape(p.shape[:-1])

    def start(self, rng: np.random.Generator) -> GpsState:
        """A bias drawn from its stationary distribution N(0, bias_std_m^2) per axis."""
        return GpsState(rng.standard_normal(3) * self.config.bias_std_m)

    def read(self, state: GpsState, true_enu_m: ArrayLike, dt_s: float,
             rng: np.random.Generator) -> tuple[GpsState, GpsReading]:
        """Advance the bias by ``dt_s`` seconds, then read the position ``true_enu_m`` (3,).

        Returns the new state and the reading (see the module docstring).
        """
        if not dt_s >= 0.0:
            raise ValueError(f"dt_s must be >= 0, got {dt_s}")
        c = self.config
        truth = np.asarray(true_enu_m, dtype=np.float64)
        phi = math.exp(-dt_s / c.bias_time_constant_s)
        # Exact discretisation of the first-order Gauss-Markov bias.
        bias = phi * state.bias_enu_m + rng.standard_normal(3) * (c.bias_std_m * math.sqrt(1.0 - phi * phi))
        noise = rng.standard_normal(3) * self.noise_std_enu_m
        h_std = math.hypot(c.horizontal_std_m, c.bias_std_m)
        v_std = math.hypot(c.vertical_std_m, c.bias_std_m)
        if len(self.denied) and self.denied_at(truth[:2])[()]:
            return GpsState(bias), GpsReading(None, h_std, v_std, FIX_NONE, 0)
        return GpsState(bias), GpsReading(truth + bias + noise, h_std, v_std, FIX_3D, c.satellites)

