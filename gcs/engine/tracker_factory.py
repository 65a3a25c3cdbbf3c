"""The tracker (estimator + planner) a scenario describes, built: the factory shared by the daemon, replay and
the benchmarks, so that they all run the same filter and planner for the same scenario.

The planner is named as the scenario and the command line name it (:mod:`gcs.core.planner_names`) and
built with the scenario's ``[planner]`` parameters (:func:`tracker_config`). The estimator is the scenario's
``[estimator]`` (:func:`gcs.config.estimator_kind`): on a world with a road graph, by default, the road
tracker (:func:`road_tracking`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Final, Literal

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario, SensorConfig, estimator_kind
from gcs.core.filters.imm_target import ImmTargetFilter
from gcs.core.filters.uif import UnscentedInformationFilter
from gcs.core.filters.vgukf import VariableGainUKF
from gcs.core.models.motion import motion_model
from gcs.core.models.sensor import SensorModel
from gcs.core.planner_names import (AOA_PLANNERS, GA_PLANNERS, K0_PLANNERS, PLANNERS, SEARCH_VARIANTS, SIGHT_PLANNERS,
                                    URBAN_PLANNERS)
from gcs.core.planners import (CrossEntropyPlanner, GeneticPlanner, LmGcrlbPlanner, OneStepHeadingPlanner,
                               OrbitPlanner, PursuitPlanner, RhcWeights, SightGeneticPlanner, SightPlanner,
                               SightWeights, StraightLinePlanner, crlb_planner)
from gcs.core.planners.airspace_guard import AirspaceGuard
from gcs.core.planners.one_step import HeadingSolver
from gcs.core.planners.problem import Planner, Visibility
from gcs.core.roads import RoadParticleFilter, table_sees
from gcs.core.roads.tracking import RoadTracking
from gcs.core.steering import course_loop
from gcs.core.tracker import TrackerConfig
from gcs.core.world import VisibilityMaps, World

__all__ = ["FROM_SCENARIO", "LOOKS_REACH_M", "horizon_steps", "planning_turn_rates", "sight_weights", "filter_sensor_models",
           "observer_sensor_model", "tracker_config", "target_imm", "road_tracking", "scenario_planner", "subset_config"]

FROM_SCENARIO: Final = "scenario"
"""Default of ``stall``: take ``planner.stall_generations`` from the scenario."""
LOOKS_REACH_M = 600.0
"""How far the road tracker's sight table looks for roofs (beyond, the sky counts as open)."""


def scenario_planner(scenario: Scenario) -> str:
    """The planner the scenario names (``[planner] kind``, one of :data:`~gcs.core.planner_names.PLANNERS`)."""
    return scenario.planner.kind


def filter_sensor_models(scenario: Scenario) -> tuple[SensorModel, ...]:
    """The filter's sensor model of every vehicle (wang2012 eq. 3-4; zuo2021 eq. 2 noise).

    Vehicles with the same sensor share one model object: the tracker groups a step's
    detections by model, and a dictionary finds an object it holds without comparing it.
    """
    shared: dict[SensorModel, SensorModel] = {}
    return tuple(shared.setdefault(model, model)
                 for model in (_sensor_model(scenario.sensor_for(vehicle)) for vehicle in scenario.vehicles))


def observer_sensor_model(scenario: Scenario) -> SensorModel:
    """The filter's model of a vehicle outside the roster (``gcs run --accept-unlisted``): the scenario's sensor."""
    return _sensor_model(scenario.sensor)


def _sensor_model(cfg: SensorConfig) -> SensorModel:
    components, std = cfg.layout()
    return SensorModel(components, std, distance_dependent=cfg.noise == "distance_dependent",
                       reference_range_m=cfg.reference_range_m)


def sight_weights(scenario: Scenario) -> SightWeights:
    """The sight objective's weights of a scenario's ``[planner.sight]``."""
    cfg = scenario.planner.sight
    return SightWeights(per_uav=cfg.per_uav_weight, information=cfg.information_weight, standoff=cfg.standoff_weight,
                        standoff_m=cfg.standoff_m, standoff_scale_m=cfg.standoff_scale_m,
                        turn_change=cfg.turn_change_weight, samples=cfg.samples, manoeuvre=cfg.manoeuvre_spread,
                        branch_samples=cfg.branch_samples)


def _planner(name: str, scenario: Scenario, generations: int | None,
             stall: int | None | Literal["scenario"]) -> Planner:
    cfg = scenario.planner
    if name == "sight_cem":
        return CrossEntropyPlanner(sight_weights(scenario), deadline_s=cfg.sight.deadline_s)
    if name == "sight_ga":
        return SightGeneticPlanner(population=100, generations=10, deadline_s=cfg.sight.deadline_s,
                                   weights=sight_weights(scenario))
    if name in SIGHT_PLANNERS:
        sight = cfg.sight
        return SightPlanner(sight_weights(scenario), sweeps=sight.sweeps, refine_sweeps=sight.refine_sweeps,
                                 refine_candidates=sight.refine_candidates, deadline_s=sight.deadline_s)
    if name in GA_PLANNERS:
        return GeneticPlanner(population=cfg.population, generations=generations or cfg.generations,
                              deadline_s=cfg.deadline_s,
                              stall=cfg.stall_generations if isinstance(stall, str) else stall)
    if name in AOA_PLANNERS:
        solvers: dict[str, Callable[[], HeadingSolver]] = {
            "gcrlb_lm": LmGcrlbPlanner, "crlb_lm": crlb_planner, "straight": StraightLinePlanner}
        solver = solvers[name]()
        max_range = min(scenario.sensor_for(v).max_range_m for v in scenario.vehicles)
        return OneStepHeadingPlanner(solver, max_detection_range_m=max_range)
    if name == "orbit":
        return OrbitPlanner()
    if name == "pursuit":
        return PursuitPlanner()
    raise ValueError(f"unknown planner {name!r}; expected one of {', '.join(PLANNERS)}")


def _visibility(world: World, planner: Planner, altitude_m: float,
                max_range_m: float) -> Callable[[NDArray[np.float64]], Visibility] | None:
    """How ``planner`` learns the visibility regions of the predicted points (wang2012 eq. 22).

    The GA asks thousands of positions a plan: the maps (a few milliseconds each to
    build) answer them cheaply. The other planners score one plan: the sight lines
    answer its few positions directly, with the same answers, and nothing is built.
    """
    if isinstance(planner, (SightPlanner, CrossEntropyPlanner, SightGeneticPlanner)):
        return None  # they ask the sight table (TrackerConfig.sight) instead
    if isinstance(planner, GeneticPlanner):
        return lambda points: VisibilityMaps(world.visibility_maps(points, altitude_m, max_range_m))
    return lambda points: world.sight_lines(points, altitude_m, max_range_m)


def horizon_steps(scenario: Scenario, planner: str) -> int:
    """Steps planned ahead: the paper's ``n`` for its GA, ``[planner.sight] horizon_steps`` (long enough to
    turn) for every other planner of the city."""
    cfg = scenario.planner
    return cfg.horizon_steps if planner in GA_PLANNERS else cfg.sight.horizon_steps


def planning_turn_rates(scenario: Scenario, autopilot_turn_rates: bool) -> NDArray[np.float64]:
    """Each vehicle's turn-rate limit for the planner: its configured one, or with ``autopilot_turn_rates`` what
    the course loop of its autopilot reaches at it (:meth:`gcs.core.steering.CourseLoop.flyable_turn_rate`)."""
    rates = [v.max_turn_rate_rad_s if not autopilot_turn_rates
             else course_loop(scenario.autopilot_for(v)).flyable_turn_rate(v.max_turn_rate_rad_s)
             for v in scenario.vehicles]
    return np.array(rates, dtype=np.float64)


def tracker_config(scenario: Scenario, world: World | None, planner: str, generations: int | None = None,
                   stall: int | None | Literal["scenario"] = FROM_SCENARIO,
                   autopilot_turn_rates: bool = False) -> TrackerConfig:
    """The tracker for a scenario and one of :data:`PLANNERS`.

    With ``autopilot_turn_rates`` each vehicle is planned at the turn rate its autopilot reaches
    (:func:`planning_turn_rates`), else at its configured limit.

    ``world`` None gives a tracker for estimation only (no visibility regions or
    restricted airspace for the planner), e.g. ``gcs replay --process``; the road
    tracker needs the world (ValueError without it).
    """
    cfg = scenario.planner
    search = _planner(planner, scenario, generations, stall)
    motion = motion_model(scenario.estimator.model, scenario.estimator.accel_psd_m2_s3)
    altitude = min(v.altitude_m for v in scenario.vehicles)  # wang2012: visibility at the lowest UAV's height
    # (the GA's maps; the sight planner asks at each UAV's own height, with roofs capped at the lowest)
    max_range = min(scenario.sensor_for(v).max_range_m for v in scenario.vehicles)
    weights = RhcWeights(w_vis=cfg.w_vis, u_max_rad_s=cfg.u_max_rad_s, w_u=cfg.w_u, w_res=cfg.w_res,
                         standoff_m=cfg.standoff_m, control_weight=cfg.control_weight,
                         standoff_weight=cfg.standoff_weight)
    sensors = filter_sensor_models(scenario)
    kind = estimator_kind(scenario)
    return TrackerConfig(
        uif=UnscentedInformationFilter(motion),
        sensors=sensors,
        planner=search,
        max_turn_rate=planning_turn_rates(scenario, autopilot_turn_rates),
        step_s=scenario.time.step_s,
        horizon_steps=horizon_steps(scenario, planner) if planner in URBAN_PLANNERS + SEARCH_VARIANTS
        else cfg.horizon_steps,
        weights=weights,
        predict_ahead=planner not in K0_PLANNERS,
        visibility=None if world is None else _visibility(world, search, altitude, max_range),
        restricted=world.in_restricted if world is not None and len(world.airspace) else None,
        initial_position_std_m=scenario.estimator.initial_position_std_m,
        initial_velocity_std_mps=scenario.estimator.initial_velocity_std_mps,
        bearing_filter=VariableGainUKF(motion) if kind == "vgukf" else None,
        target_imm=target_imm(scenario) if kind == "imm" else None,
        sight=None if world is None else world.sight_table(altitude, sensors[0].target_height_m, cfg.sight.reach_m),
        guard=AirspaceGuard(margin_m=cfg.airspace_margin_m) if world is None
        else AirspaceGuard(world.airspace, cfg.airspace_margin_m),
        max_range_m=max_range,
        road=road_tracking(scenario, world) if kind == "road" else None,
    )


def target_imm(scenario: Scenario) -> ImmTargetFilter:
    """The CV + coordinated-turn IMM of a scenario's ``[estimator]`` (kind ``imm``)."""
    est = scenario.estimator
    p = est.mode_switch_probability
    return ImmTargetFilter(cv_accel_psd_m2_s3=est.accel_psd_m2_s3, ct_accel_psd_m2_s3=est.turn_accel_psd_m2_s3,
                           turn_psd_rad2_s3=est.turn_rate_psd_rad2_s3,
                           initial_turn_std_rad_s=est.initial_turn_rate_std_rad_s,
                           transition=((1.0 - p, p), (2.0 * p, 1.0 - 2.0 * p)))


def road_tracking(scenario: Scenario, world: World | None) -> RoadTracking:
    """The road tracker of a scenario's ``[estimator.road]`` on the world's road graph, with negative information
    from the world's sight table (at the lowest vehicle's altitude, out to :data:`LOOKS_REACH_M`) and the
    sensors' range. ValueError without a world or a road graph."""
    if world is None or world.roads is None:
        raise ValueError(f"scenario {scenario.name!r}: the road estimator needs the world's road graph "
                         "(build the world; [estimator] kind = 'duif' tracks without roads)")
    cfg = scenario.estimator.road
    graph_filter = RoadParticleFilter(
        world.roads, speed_psd_m2_s3=cfg.speed_psd_m2_s3, max_speed_mps=cfg.max_speed_mps,
        turn_probability=cfg.turn_probability, leave_rate_per_s=cfg.off_road_rate_per_s,
        rejoin_rate_per_s=cfg.rejoin_rate_per_s, rejoin_m=cfg.rejoin_m, off_road_psd_m2_s3=cfg.off_road_psd_m2_s3,
        spread_m=cfg.spread_m, initial_off_road=cfg.initial_off_road, particles=cfg.particles)
    altitude = min(v.altitude_m for v in scenario.vehicles)
    max_range = min(scenario.sensor_for(v).max_range_m for v in scenario.vehicles)
    table = world.sight_table(altitude, filter_sensor_models(scenario)[0].target_height_m, LOOKS_REACH_M)
    return RoadTracking(graph_filter, table_sees(table, max_range), cfg.detection_probability, cfg.seed,
                        cfg.horizon_samples)


def subset_config(config: TrackerConfig, indices: tuple[int, ...]) -> TrackerConfig:
    """The tracker for some of the roster's vehicles (their sensors and turn limits), e.g. those alive now."""
    return replace(config, sensors=tuple(config.sensors[i] for i in indices),
                   max_turn_rate=config.max_turn_rate[list(indices)])
