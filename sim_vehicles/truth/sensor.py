"""The vehicles' target sensor: range/azimuth/elevation with noise, range limit and occlusion.

Measurement formulas are this module's own (docs/design.md: the simulator never uses
the filters' ``h(x)``). A detection needs the target within ``max_range_m`` and
an unobstructed line of sight (``line_of_sight`` is the world's exact test);
otherwise ``detected`` is False and no values are produced, exactly like a real
gimballed sensor that loses the target behind a building (wang2012 section 2.4).

Noise: constant standard deviations, or zuo2021 eq. (2), where every standard
deviation grows in proportion to the range beyond ``reference_range_m``:
``sigma(r) = sigma0 * max(r / r0, 1)`` (:meth:`TargetSensor.std_at`), evaluated
at the TRUE slant range, which is also what a simulated vehicle reports as the
measurement's standard deviation (the noisy range would bias it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.config import SensorConfig

__all__ = ["TargetSensor", "Observation", "exact_measurements", "noisy_measurements"]

COMPONENTS = ("range", "azimuth", "elevation")


def exact_measurements(target_xyz: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """Noise-free range, azimuth, elevation of targets (..., 3) seen from vehicles (..., 3), shape (..., 3).

    Range is the 3-D distance, azimuth ``atan2(north, east)`` of target minus
    vehicle, elevation ``atan2(up, ground distance)`` (negative below).
    """
    east = target_xyz[..., 0] - vehicle_xyz[..., 0]
    north = target_xyz[..., 1] - vehicle_xyz[..., 1]
    up = target_xyz[..., 2] - vehicle_xyz[..., 2]
    ground = np.sqrt(east * east + north * north)
    return np.stack([np.sqrt(ground * ground + up * up), np.arctan2(north, east), np.arctan2(up, ground)], axis=-1)


@dataclass(frozen=True)
class Observation:
    """One step of sensing by V vehicles: ``detected`` (V,), ``values`` (V, m) (NaN where not detected)."""

    detected: NDArray[np.bool_]
    values: NDArray[np.float64]
    components: tuple[str, ...]


@dataclass(frozen=True)
class TargetSensor:
    """Truth sensor. ``std`` per component in ``components`` (range m, angles rad)."""

    components: tuple[str, ...]
    std: tuple[float, ...]
    max_range_m: float
    distance_dependent: bool = False
    reference_range_m: float = 1500.0

    @classmethod
    def from_config(cls, cfg: SensorConfig) -> TargetSensor:
        """The sensor a ``[sensor]`` table describes (components: :meth:`SensorConfig.layout`);
        ``noise = "distance_dependent"`` selects zuo2021 eq. (2) about ``reference_range_m``."""
        components, std = cfg.layout()
        return cls(components, std, cfg.max_range_m, distance_dependent=cfg.noise == "distance_dependent",
                   reference_range_m=cfg.reference_range_m)

    def _scale(self, slant_range_m: NDArray[np.float64]) -> NDArray[np.float64]:
        """zuo2021 eq. (2) factor ``max(r / r0, 1)`` (ones for constant noise), same shape as the range."""
        if self.distance_dependent:
            return np.maximum(slant_range_m / self.reference_range_m, 1.0)
        return np.ones_like(slant_range_m)

    def std_at(self, slant_range_m: ArrayLike) -> NDArray[np.float64]:
        """Standard deviation of each component (..., m) at the true slant range (...), metres / radians.

        Constant noise: ``std`` everywhere. Distance-dependent (zuo2021 eq. 2):
        ``std * max(r / reference_range_m, 1)``.
        """
        r = np.asarray(slant_range_m, dtype=np.float64)
        return np.asarray(self.std, dtype=np.float64) * self._scale(r)[..., None]

    def observe(
        self,
        target_xyz: NDArray[np.float64],
        vehicle_xyz: NDArray[np.float64],
        line_of_sight: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.bool_]] | None,
        rng: np.random.Generator,
    ) -> Observation:
        """Sense the target (3,) from each vehicle (V, 3)."""
        exact = exact_measurements(target_xyz, vehicle_xyz)
        slant = exact[:, 0]
        clear = np.ones(len(vehicle_xyz), dtype=bool) if line_of_sight is None else line_of_sight(
            np.broadcast_to(target_xyz, vehicle_xyz.shape), vehicle_xyz)
        detected = clear & (slant <= self.max_range_m)
        values = noisy_measurements(exact, self.components, self.std, self._scale(slant), rng)
        values[~detected] = np.nan
        return Observation(detected, values, self.components)


    def measure_points(self, points_xyz: NDArray[np.float64], vehicle_xyz: NDArray[np.float64],
                       rng: np.random.Generator) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Noisy measurements (k, m) of points (k, 3) from one vehicle (3,), whatever is in the way (false
        alarms need no line of sight), and their standard deviations (k, m) at the true slant range."""
        exact = exact_measurements(points_xyz, np.broadcast_to(vehicle_xyz, points_xyz.shape))
        slant = exact[:, 0]
        values = noisy_measurements(exact, self.components, self.std, self._scale(slant), rng)
        return values, self.std_at(slant)


def noisy_measurements(exact: NDArray[np.float64], components: tuple[str, ...], std: tuple[float, ...],
                       scale: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float64]:
    """The measured ``components`` (k, m) of exact range/azimuth/elevation triples (k, 3): Gaussian noise of
    ``std * scale`` (``scale`` (k,), zuo2021 eq. 2's factor or ones), the azimuth wrapped into [-pi, pi),
    the elevation clipped at the vertical (a sensor cannot look past it) and the range kept >= 0."""
    noise = rng.standard_normal((len(exact), len(components))) * np.asarray(std) * scale[:, None]
    values = exact[:, [COMPONENTS.index(c) for c in components]] + noise
    if "azimuth" in components:
        a = components.index("azimuth")
        values[:, a] = np.mod(values[:, a] + np.pi, 2.0 * np.pi) - np.pi
    if "elevation" in components:
        e = components.index("elevation")
        values[:, e] = np.clip(values[:, e], -0.5 * np.pi, 0.5 * np.pi)
    if "range" in components:
        r = components.index("range")
        values[:, r] = np.maximum(values[:, r], 0.0)
    return values
