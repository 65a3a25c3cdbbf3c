"""``[multitarget]``: the daemon tracks every target in sight, not one (:mod:`gcs.core.multitarget`).

Without the table the daemon runs the single-target estimator of ``[estimator]``. With it,
each decision step's detections, none of which says which target it is, go to the
multi-target tracker (GNN or JPDA association, M-of-N confirmation, deletion), every
confirmed track is published on ``<prefix>/track/t<id>``, and the UAVs are shared
between the tracks by assignment (:mod:`gcs.core.multitarget.planning`). The sensor's
``detection_probability`` and ``clutter_rate`` (``[sensor]``) are the tracker's ``P_D``
and clutter. The defaults are those ``gcs-bench multitarget`` and ``gcs-bench sharing``
measure.

``kind = "auto"`` (the default) is the road tracker
(:class:`gcs.core.multitarget.road_tracker.RoadMultiTargetTracker`, every track a particle cloud on
the road graph, its motion that of ``[estimator.road]``) wherever the world has a road graph, and
the Gaussian tracker (:class:`gcs.core.multitarget.MultiTargetTracker`, constant velocity) elsewhere
(:func:`multitarget_kind`), as ``[estimator] kind = "auto"`` chooses for one target. ``"gaussian"``
names the Gaussian tracker on any world; ``"road"`` needs a road graph.
"""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec

from gcs.config.base import Config, NonNegative, Positive
from gcs.config.city import CityConfig
from gcs.config.estimator import has_road_graph
from gcs.core.planner_names import MULTITARGET_PLANNERS

__all__ = ["MultiTargetConfig", "check_multitarget", "multitarget_kind"]
"""The planners that share the UAVs between targets (the sequential sight search's ``solve_assigned``)."""

Window = Annotated[int, msgspec.Meta(ge=1, le=62)]


class MultiTargetConfig(Config, frozen=True):
    """The multi-target tracker and the sharing of the UAVs between its tracks.

    ``kind``: ``auto``, ``road`` or ``gaussian`` (module docstring); ``road_particles``: the
    particles of each road track.
    ``association``: ``gnn`` or ``jpda``; ``accel_psd_m2_s3``: the tracks' constant-velocity
    white acceleration; ``gate_probability``: ``P_G`` of the chi-square gate;
    ``confirm_m`` of ``confirm_n``: the confirmation rule; ``max_misses``: consecutive
    scans that a sensor covered without a detection that delete a track;
    ``max_position_trace_m2``: a track coasting beyond this ``tr P_pp`` is deleted;
    ``initial_velocity_std_mps``: a new track's velocity spread; ``starvation_s``: the time
    in which an unseen track's claim on the UAVs doubles; ``forget_s``: how long a deleted
    track's target is still searched for.
    """

    kind: Literal["auto", "road", "gaussian"] = "auto"
    road_particles: Annotated[int, msgspec.Meta(ge=2, le=10_000)] = 200
    association: Literal["gnn", "jpda"] = "jpda"
    accel_psd_m2_s3: NonNegative = 2.0
    gate_probability: Annotated[float, msgspec.Meta(gt=0.0, lt=1.0)] = 0.99
    confirm_m: Window = 3
    confirm_n: Window = 4
    max_misses: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 5
    max_position_trace_m2: Positive = 2.0e4
    initial_velocity_std_mps: Positive = 10.0
    starvation_s: Positive = 20.0
    forget_s: Positive = 90.0


def multitarget_kind(config: MultiTargetConfig, city: CityConfig) -> str:
    """The many-target tracker a scenario runs: ``road`` or ``gaussian``, ``auto`` resolved (module docstring)."""
    if config.kind != "auto":
        return config.kind
    return "road" if has_road_graph(city) else "gaussian"


def check_multitarget(config: MultiTargetConfig | None, sensors: list, planner_kind: str,
                      city: CityConfig | None = None) -> list[str]:
    """The rules a schema cannot express: M <= N; every vehicle's sensor (``sensors``, SensorConfig) measures
    range (a track starts from one detection's ground position) and detects at all; a planner that can
    share the UAVs (``sight`` or ``sight_k0``); and ``kind = "road"`` in a ``city`` with a road graph."""
    if config is None:
        return []
    problems = []
    if config.kind == "road" and city is not None and not has_road_graph(city):
        problems.append("$.multitarget.kind: 'road' needs a road graph (a generated city, or [city] roads_geojson)")
    if config.confirm_m > config.confirm_n:
        problems.append(f"$.multitarget.confirm_m: {config.confirm_m} is more than confirm_n {config.confirm_n}")
    kinds = sorted({sensor.kind for sensor in sensors})
    if kinds != ["range_bearing"]:
        problems.append("$.multitarget: needs every vehicle's sensor of kind 'range_bearing' (tracks start from "
                        f"a detection's range), got {', '.join(kinds)}")
    if any(sensor.detection_probability <= 0.0 for sensor in sensors):
        problems.append("$.multitarget: needs every sensor's detection_probability above 0")
    if planner_kind not in MULTITARGET_PLANNERS:
        problems.append(f"$.planner.kind: {planner_kind!r} cannot share the UAVs between targets; "
                        f"[multitarget] needs one of {', '.join(MULTITARGET_PLANNERS)}")
    return problems
