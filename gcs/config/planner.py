"""``[planner]``: which planner steers the UAVs (``kind``, named as on the command line:
:mod:`gcs.core.planner_names`) and its parameters; ``[planner.sight]`` those of the sight planner."""

from __future__ import annotations

from typing import Annotated

import msgspec

from gcs.config.base import Config, NonNegative, Positive
from gcs.core.planner_names import DEFAULT_PLANNER, PLANNERS

__all__ = ["SightConfig", "PlannerConfig", "check_planner"]


class SightConfig(Config, frozen=True):
    """The sight planner (``[planner.sight]``): objective weights and search budget.

    The objective (:mod:`gcs.core.planners.sight`) counts, in seen steps, the
    probability that at least one UAV sees the target at each of ``horizon_steps``
    steps over ``samples`` samples of the prediction (widened by
    ``manoeuvre_spread`` times the target's speed per second ahead; of the road
    tracker's prediction, ``branch_samples`` of its samples down every branch), from at most
    ``reach_m`` away; plus ``per_uav_weight`` for each UAV's own sight (shared
    among the UAVs), ``information_weight`` for the share of the position variance
    removed, a stand-off pull worth at most ``standoff_weight`` (< 1 seen step)
    toward ``standoff_m`` from the target (half-strength ``standoff_scale_m``
    beyond it), and ``turn_change_weight`` per full-rate change of turn. The
    search (:mod:`gcs.core.planners.sequential`) runs ``sweeps`` rounds of the
    manoeuvre library and ``refine_sweeps`` of ``refine_candidates``
    perturbations per vehicle, stopping at ``deadline_s`` of data time in the
    daemon.
    """

    horizon_steps: Annotated[int, msgspec.Meta(ge=1, le=100)] = 10
    samples: Annotated[int, msgspec.Meta(ge=1, le=256)] = 16
    branch_samples: Annotated[int, msgspec.Meta(ge=1, le=256)] = 32
    per_uav_weight: NonNegative = 0.5
    information_weight: NonNegative = 0.5
    standoff_weight: Annotated[float, msgspec.Meta(ge=0.0, lt=1.0)] = 0.9
    standoff_m: NonNegative = 100.0
    standoff_scale_m: Positive = 150.0
    turn_change_weight: NonNegative = 0.002
    manoeuvre_spread: NonNegative = 0.6
    reach_m: Positive = 450.0
    sweeps: Annotated[int, msgspec.Meta(ge=1, le=100)] = 2
    refine_sweeps: Annotated[int, msgspec.Meta(ge=0, le=100)] = 1
    refine_candidates: Annotated[int, msgspec.Meta(ge=1, le=10_000)] = 24
    deadline_s: Positive = 0.5


class PlannerConfig(Config, frozen=True):
    """Heading planner: ``kind`` names it as ``gcs run --planner`` does (:mod:`gcs.core.planner_names`).
    ``sight`` (the default): the probability that at least one UAV sees the target over the
    predicted distribution, searched vehicle by vehicle (``[planner.sight]``); ``sight_k0``: the
    same on the current estimate; ``sight_cem``, ``sight_ga``: the same objective searched
    otherwise. ``ga_k5``: wang2012 section 4 (RHC cost eq. 20-26, GA eq. 27-29, with the fields
    below) on the k+5 predictions; ``ga_k0``: the same on the current estimate; ``orbit`` and
    ``pursuit``: baselines. ``gcrlb_lm``: zuo2021 section 4 (tr GCRLB, penalty +
    Levenberg-Marquardt); ``crlb_lm`` (Dogancay's constant-noise CRLB) and ``straight`` are
    zuo2021's baselines.

    ``airspace_margin_m``: every planner's plan keeps this far from restricted airspace
    (:mod:`gcs.core.planners.airspace_guard`)."""

    kind: str = DEFAULT_PLANNER
    sight: SightConfig = SightConfig()
    airspace_margin_m: NonNegative = 25.0
    horizon_steps: Annotated[int, msgspec.Meta(ge=1, le=100)] = 5
    population: Annotated[int, msgspec.Meta(ge=2, le=10_000)] = 50
    generations: Annotated[int, msgspec.Meta(ge=1, le=100_000)] = 200
    stall_generations: Annotated[int, msgspec.Meta(ge=1, le=100_000)] | None = None
    """Stop the GA after this many generations without improvement (None: run them all)."""
    deadline_s: Positive = 1.0
    standoff_m: Positive = 300.0
    w_vis: NonNegative = 0.0
    u_max_rad_s: Positive = 0.1
    w_u: NonNegative = 10.0
    w_res: NonNegative = 1e6
    control_weight: NonNegative = 0.01
    """Scale of J_u against J_in (ours: the paper adds them unscaled)."""
    standoff_weight: NonNegative = 10.0
    """Numerator of the stand-off fitness f_dis of eq. (29) (ours)."""


def check_planner(planner: PlannerConfig) -> list[str]:
    """``$.planner.kind`` names a planner (the problem, listing the names, else nothing)."""
    if planner.kind in PLANNERS:
        return []
    return [f"$.planner.kind: unknown planner {planner.kind!r}; expected one of: {', '.join(PLANNERS)}"]
