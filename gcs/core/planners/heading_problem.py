"""The decision of zuo2021 section 4 as data: :class:`HeadingProblem` -> :class:`HeadingResult`.

At decision step k every vehicle i picks the heading ``phi_i(k)`` it flies for the next step
(eq. 35); the objective is the trace of the bound on the predicted target position (eq. 34,
:func:`trace_bound`), subject to the turn limit (36), the detection range (37) and the
inter-vehicle distance band (38)-(39). :func:`constraint_excess` measures how far next positions
lie beyond the range and band bounds (with the lookahead of :mod:`gcs.core.planners.lm_gcrlb`),
:func:`violations` counts them against the true bounds. The planners that solve the problem are
in :mod:`gcs.core.planners.lm_gcrlb`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.uif import GaussianEstimate
from gcs.core.gcrlb import fisher_information
from gcs.core.models.sensor import SensorModel

__all__ = ["HeadingProblem", "HeadingResult", "Violations", "constraint_excess", "information", "next_positions",
           "trace_bound", "violations"]


@dataclass(frozen=True)
class HeadingProblem:
    """Everything the planner needs at decision step k (zuo2021 eq. 34-39); pure data.

    Attributes
    ----------
    vehicle_xyz : ndarray (M, 3)
        ENU positions ``S_i(k)`` now, m.
    heading : ndarray (M,)
        ``phi_i(k-1)``, the heading flown now (rad, ENU: from east, counter-clockwise).
    speed_mps : ndarray (M,)
        ``v`` of eq. (35).
    step_s : float
        ``T``, the decision step.
    max_turn_rad : ndarray (M,)
        ``phi_max`` of eq. (36): the largest heading change in one step, rad.
    target_xy : ndarray (2,)
        Predicted target position at k+1, ``x_{k+1|k}``.
    prior_information : ndarray (2, 2)
        Predicted information of that position, ``(P_{k+1|k})^{-1}`` of the position block.
    sensors : sequence of SensorModel, length M
    max_detection_range_m, min_separation_m, max_separation_m : float
        ``r_dmax`` (eq. 37), ``r_smin`` and ``r_smax`` (eq. 38-39).
    """

    vehicle_xyz: NDArray[np.float64]
    heading: NDArray[np.float64]
    speed_mps: NDArray[np.float64]
    step_s: float
    max_turn_rad: NDArray[np.float64]
    target_xy: NDArray[np.float64]
    prior_information: NDArray[np.float64]
    sensors: Sequence[SensorModel]
    max_detection_range_m: float = 20_000.0
    min_separation_m: float = 200.0
    max_separation_m: float = 7_500.0

    def __post_init__(self) -> None:
        m = len(self.sensors)
        shapes = {"vehicle_xyz": (m, 3), "heading": (m,), "speed_mps": (m,), "max_turn_rad": (m,),
                  "target_xy": (2,), "prior_information": (2, 2)}
        for name, shape in shapes.items():
            value = np.asarray(getattr(self, name), dtype=np.float64)
            if value.ndim == 0 and name in ("speed_mps", "max_turn_rad"):  # one value for every vehicle
                value = np.full(shape, float(value))
            if value.shape != shape:
                raise ValueError(f"{name} must have shape {shape} for {m} sensors, got {value.shape}")
            object.__setattr__(self, name, value)
        if not np.all(self.max_turn_rad >= 0.0) or not self.step_s > 0.0:
            raise ValueError("max_turn_rad must be >= 0 and step_s > 0")
        if not 0.0 <= self.min_separation_m <= self.max_separation_m:
            raise ValueError("need 0 <= min_separation_m <= max_separation_m")

    @classmethod
    def from_prediction(
        cls,
        prediction: GaussianEstimate,
        vehicle_xyz: NDArray[np.float64],
        heading: NDArray[np.float64],
        speed_mps: NDArray[np.float64] | float,
        step_s: float,
        max_turn_rad: NDArray[np.float64] | float,
        sensors: Sequence[SensorModel],
        **limits: float,
    ) -> HeadingProblem:
        """The problem for the target prediction ``x_{k+1|k}`` (state ``[x, y, ...]``)."""
        return cls(vehicle_xyz, heading, np.asarray(speed_mps, dtype=np.float64), step_s,
                   np.asarray(max_turn_rad, dtype=np.float64), prediction.mean[:2],
                   np.linalg.inv(prediction.cov[:2, :2]).astype(np.float64, copy=False), tuple(sensors), **limits)

    @cached_property
    def pairs(self) -> tuple[NDArray[np.int_], NDArray[np.int_]]:
        """Indices ``(i, j)``, ``i < j``, of the M (M - 1) / 2 vehicle pairs."""
        return np.triu_indices(len(self.sensors), k=1)

    @cached_property
    def turn_radius_m(self) -> NDArray[np.float64]:
        """``R = v T / phi_max`` (M,), the radius of a turn at the limit; 0 for a vehicle that cannot turn."""
        travel = self.speed_mps * self.step_s
        return np.divide(travel, self.max_turn_rad, out=np.zeros_like(travel), where=self.max_turn_rad > 0)


@dataclass(frozen=True)
class Violations:
    """Constraints violated by the chosen next positions, counted against the true bounds."""

    turn: int = 0
    detection: int = 0
    too_close: int = 0
    too_far: int = 0

    @property
    def total(self) -> int:
        """All violated constraint instances."""
        return self.turn + self.detection + self.too_close + self.too_far


@dataclass(frozen=True)
class HeadingResult:
    """Outcome of a solve (Problem -> solve -> Result).

    ``heading`` (M,) is ``phi(k)``, flown for the next step; ``heading_change`` and
    ``turn_rate_rad_s`` (its mean rate over the step) are relative to ``phi(k-1)``.
    ``objective`` is ``tr(GCRLB)`` of eq. (34) at the chosen positions with the
    problem's sensor models (whatever the planner minimised), ``initial_objective``
    the same for unchanged headings; ``cost`` is what the planner minimised (LM:
    the penalised, normalised cost of eq. 40). ``evaluations`` counts the heading
    vectors scored, ``iterations`` the LM iterations.
    """

    success: bool
    heading: NDArray[np.float64]
    heading_change: NDArray[np.float64]
    turn_rate_rad_s: NDArray[np.float64]
    objective: float
    initial_objective: float
    cost: float
    violations: Violations
    evaluations: int
    iterations: int
    elapsed_s: float
    message: str


def next_positions(problem: HeadingProblem, heading_change: NDArray[np.float64]) -> NDArray[np.float64]:
    """``S_i(k+1)`` of eq. (35) for heading changes (..., M): shape (..., M, 3), altitude kept."""
    heading = problem.heading + heading_change
    travel = problem.speed_mps * problem.step_s
    xyz = np.broadcast_to(problem.vehicle_xyz, heading.shape + (3,)).copy()
    xyz[..., 0] += travel * np.cos(heading)
    xyz[..., 1] += travel * np.sin(heading)
    positions: NDArray[np.float64] = xyz
    return positions


def information(problem: HeadingProblem, sensors: Sequence[SensorModel], xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """``Y^- + J`` of eq. (34) for next positions (..., M, 3): shape (..., 2, 2).

    Vehicles with the same sensor model go through :func:`~gcs.core.gcrlb.fisher_information`
    together, as a batch axis (one call per distinct sensor instead of one per vehicle).
    """
    groups: dict[SensorModel, list[int]] = {}
    for index, sensor in enumerate(sensors):
        groups.setdefault(sensor, []).append(index)
    info = problem.prior_information
    for sensor, members in groups.items():
        batch = xyz[..., members, :][..., None, :]  # (..., G, 1, 3): G vehicles, one sensor each
        info = info + fisher_information((sensor,), problem.target_xy, batch).sum(axis=-3)  # eq. (15)-(17)
    return info


def trace_bound(problem: HeadingProblem, heading_change: NDArray[np.float64],
                sensors: Sequence[SensorModel] | None = None) -> NDArray[np.float64]:
    """``f`` of eq. (34) for heading changes (..., M), shape (...); ``sensors`` default to the problem's."""
    info = information(problem, problem.sensors if sensors is None else sensors, next_positions(problem, heading_change))
    a, b, c = info[..., 0, 0], info[..., 0, 1], info[..., 1, 1]
    return (a + c) / (a * c - b * b)


def constraint_excess(problem: HeadingProblem, xyz: NDArray[np.float64], margin_m: float,
            heading: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Metres beyond each bound of eq. (37)-(39), tightened by ``margin_m``, >= 0: shape (..., M + 2 P).

    With ``heading`` (..., M), each distance is first moved by the drift still to come
    after k+1 if the vehicles then turned at their limit (module docstring): ``R c^2``
    per vehicle, ``c`` its speed fraction toward the bound.
    """
    to_target = problem.target_xy - xyz[..., :2]  # (..., M, 2)
    range_m = np.hypot(to_target[..., 0], to_target[..., 1])
    i, j = problem.pairs
    offset = xyz[..., i, :2] - xyz[..., j, :2]  # (..., P, 2), from j to i
    apart = np.hypot(offset[..., 0], offset[..., 1])
    outward = inward = closing = 0.0
    if heading is not None:
        radius = problem.turn_radius_m
        unit = np.stack([np.cos(heading), np.sin(heading)], axis=-1)  # (..., M, 2)
        receding = -np.einsum("...k,...k->...", unit, to_target) / range_m  # c away from the target
        outward = radius * np.maximum(receding, 0.0) ** 2
        along = offset / apart[..., None]
        c_i = np.einsum("...k,...k->...", unit[..., i, :], along)  # i moving away from j
        c_j = -np.einsum("...k,...k->...", unit[..., j, :], along)  # j moving away from i
        inward = radius[i] * np.maximum(c_i, 0.0) ** 2 + radius[j] * np.maximum(c_j, 0.0) ** 2
        closing = radius[i] * np.maximum(-c_i, 0.0) ** 2 + radius[j] * np.maximum(-c_j, 0.0) ** 2
    violations: NDArray[np.float64] = np.maximum(np.concatenate([
        range_m + outward - (problem.max_detection_range_m - margin_m),  # eq. (37), (42)
        (problem.min_separation_m + margin_m) - (apart - closing),  # eq. (39), (44)
        apart + inward - (problem.max_separation_m - margin_m),  # eq. (38), (43)
    ], axis=-1), 0.0)
    return violations


def violations(problem: HeadingProblem, heading_change: NDArray[np.float64]) -> Violations:
    """Constraints (36)-(39) violated by one heading change (M,), against the true bounds."""
    excess = constraint_excess(problem, next_positions(problem, heading_change), 0.0)
    m, p = len(problem.sensors), len(problem.pairs[0])
    turn = np.abs(heading_change) > problem.max_turn_rad * (1.0 + 1e-12)
    return Violations(int(turn.sum()), int((excess[:m] > 0).sum()), int((excess[m:m + p] > 0).sum()),
                      int((excess[m + p:] > 0).sum()))
