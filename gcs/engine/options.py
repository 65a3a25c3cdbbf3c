"""What changes the engine's decisions: :class:`EngineOptions` (``gcs run`` and ``gcs replay --process`` take the
same flags)."""

from __future__ import annotations

from dataclasses import dataclass

from gcs.engine.federation import FederationOptions

__all__ = ["EngineOptions"]


@dataclass(frozen=True)
class EngineOptions:
    """What changes the engine's decisions (``gcs run`` and ``gcs replay --process`` take the same flags).

    ``prefix``: the key space's; ``accept_unlisted``: fuse vehicles outside the roster too;
    ``navigation``: :data:`gcs.engine.navigation.NAVIGATION_MODES`; ``max_wait_s``: a step's wait for
    missing reports (loop time); ``planner``: the planner's name (None: the scenario's);
    ``plan_fraction``: share of a step of data time the planner may use; ``handback_after_lost_s``:
    stamp time without the target before the vehicles are given back; ``plan_every_step``: hand every
    fused step to a free planner, without the :func:`~gcs.engine.memory.plan_interval_s` that spares a
    live loop's time (``gcs replay --plan``, whose plans are reproducible and made at leisure);
    ``autopilot_turn_rates``: plan each vehicle at the turn rate its autopilot reaches under the daemon's
    commands (:meth:`gcs.core.steering.CourseLoop.flyable_turn_rate`), as the daemon steers real and
    simulated autopilots; False plans at the scenario's own limits, for vehicles that fly the plan
    itself (the benchmarks' in-process loops); ``federation``: the engine is a member of a federation of
    daemons (:mod:`gcs.engine.federation`; with ``[multitarget]`` only).
    """

    prefix: str = "gcs"
    accept_unlisted: bool = False
    navigation: str = "auto"
    max_wait_s: float = 0.5
    planner: str | None = None
    plan_fraction: float = 0.6
    handback_after_lost_s: float = 60.0
    plan_every_step: bool = False
    autopilot_turn_rates: bool = True
    federation: FederationOptions | None = None
