"""``[estimator]``: the single-target estimator (``kind``) and its parameters; ``[estimator.road]`` those of the
road tracker.

``kind = "auto"`` (the default) is the road tracker wherever the world has a road graph (a
generated city's street grid, or any city's ``[city] roads_geojson``) and the DUIF elsewhere
(:func:`estimator_kind`). A scenario whose target is no road vehicle names its estimator.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

import msgspec

from gcs.config.base import Config, NonNegative, Positive
from gcs.config.city import CityConfig

if TYPE_CHECKING:
    from gcs.config import Scenario

__all__ = ["RoadEstimatorConfig", "EstimatorConfig", "has_road_graph", "estimator_kind", "check_estimator"]

Probability = Annotated[float, msgspec.Meta(ge=0.0, le=1.0)]


class RoadEstimatorConfig(Config, frozen=True):
    """The road tracker (``[estimator.road]``; :class:`gcs.core.roads.RoadParticleFilter`, docs/road_tracking.md).

    ``particles`` hypotheses on the road graph (or off it); along the road the speed is a
    random walk of density ``speed_psd_m2_s3`` up to ``max_speed_mps``; at a junction the car
    turns with ``turn_probability`` (the turns share it; straight on keeps the rest). It leaves
    the road at ``off_road_rate_per_s`` and, within ``rejoin_m`` of a road, comes back at
    ``rejoin_rate_per_s``; off the road it moves with the white-noise acceleration
    ``off_road_psd_m2_s3``; a new track puts ``initial_off_road`` of its weight off the road. A
    hypothesis on the road stands for ``spread_m`` of road either side. A vehicle that had a
    hypothesis in sight and detected nothing weighs it by ``1 - detection_probability``
    (negative information; 0 leaves it out). The k+1..k+n prediction drives
    ``horizon_samples`` particles on through the graph. The random draws of a step come from a
    generator seeded with ``seed`` and the step's stamp, so a replay gives the same track.
    """

    particles: Annotated[int, msgspec.Meta(ge=2, le=100_000)] = 400
    horizon_samples: Annotated[int, msgspec.Meta(ge=1, le=4096)] = 64
    turn_probability: Probability = 0.5
    speed_psd_m2_s3: NonNegative = 1.0
    max_speed_mps: Positive = 40.0
    off_road_rate_per_s: NonNegative = 0.01
    rejoin_rate_per_s: NonNegative = 0.2
    rejoin_m: NonNegative = 25.0
    off_road_psd_m2_s3: NonNegative = 2.0
    spread_m: NonNegative = 3.0
    initial_off_road: Probability = 0.05
    detection_probability: Annotated[float, msgspec.Meta(ge=0.0, lt=1.0)] = 0.9
    seed: Annotated[int, msgspec.Meta(ge=0)] = 0


class EstimatorConfig(Config, frozen=True):
    """Target estimator. ``auto``: ``road`` where the world has a road graph, else ``duif``
    (:func:`estimator_kind`). ``road``: the particle filter on the road graph with an off-road
    mode (``[estimator.road]``; ``model`` must be ``cv2d``, the layout of its point estimate);
    ``duif``: wang2012 section 3 (range-bearing sensors); ``vgukf``: zuo2021's ML
    initialisation and variable-gain UKF (bearing-only sensors); ``imm``: an IMM of constant
    velocity (``accel_psd_m2_s3``) and coordinated turn, each mode updated by the DUIF (the
    switching machinery of feng2019; ``model`` must be ``cv2d``). ``model`` names the state
    layout."""

    kind: Literal["auto", "road", "duif", "vgukf", "imm"] = "auto"
    model: Literal["cv2d", "ca2d"] = "cv2d"
    accel_psd_m2_s3: NonNegative = 1.96
    initial_position_std_m: Positive = 50.0
    initial_velocity_std_mps: Positive = 10.0
    turn_accel_psd_m2_s3: NonNegative = 2.0
    """``imm``: white acceleration of the coordinated-turn mode (``accel_psd_m2_s3`` is then the
    constant-velocity mode's, which can be much quieter than a single model's)."""
    turn_rate_psd_rad2_s3: NonNegative = 0.01
    """``imm``: random walk of the coordinated-turn mode's turn rate."""
    initial_turn_rate_std_rad_s: Positive = 0.3
    """``imm``: spread of the turn rate when a track starts (and of the CV mode's)."""
    mode_switch_probability: Annotated[float, msgspec.Meta(gt=0.0, lt=1.0)] = 0.05
    """``imm``: probability per step of leaving constant velocity (twice that of leaving the turn)."""
    road: RoadEstimatorConfig = RoadEstimatorConfig()


def has_road_graph(city: CityConfig) -> bool:
    """Whether the city's world has a road graph: a generated city (its street grid), or ``roads_geojson``."""
    return city.kind == "generated" or city.roads_geojson is not None


def estimator_kind(scenario: Scenario) -> str:
    """The estimator the scenario runs: its ``[estimator] kind``, with ``auto`` resolved (module docstring)."""
    kind = scenario.estimator.kind
    if kind != "auto":
        return kind
    return "road" if has_road_graph(scenario.city) else "duif"


def check_estimator(scenario: Scenario) -> list[str]:
    """The ``[estimator]`` rules a schema cannot express: the road tracker needs roads and ``cv2d``; so does the IMM."""
    problems = []
    kind = estimator_kind(scenario)
    if scenario.estimator.kind == "road" and not has_road_graph(scenario.city):
        problems.append("$.estimator.kind: 'road' needs a road graph (a generated city, or [city] roads_geojson)")
    if kind in ("road", "imm") and scenario.estimator.model != "cv2d":
        named = "" if scenario.estimator.kind == kind else " ('auto' in a city with roads; name kind = 'duif' for ca2d)"
        problems.append(f"$.estimator.model: the {kind} estimator{named} needs model = 'cv2d'")
    return problems
