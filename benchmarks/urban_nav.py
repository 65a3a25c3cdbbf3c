"""The vehicles' own navigation in the in-process closed loop (``gcs-bench urban --gps-denied``).

:func:`benchmarks.urban.run_closed_loop` normally gives the tracker and the planner
the vehicles' true positions. With a :class:`FleetNavigation` it gives them what
each vehicle's navigation believes instead, and the target filter gets that
belief's covariance with every detection (:class:`gcs.core.tracker.Detection`).
The sensors still measure from the true positions. Three kinds, on the same
truth and the same GPS and INS draws (paired):

* ``perfect``: the true position, no uncertainty (the loop without navigation);
* ``raw_gps``: what the simulated vehicles report today
  (:func:`sim_vehicles.scene.simple_navigation`): the GPS fix, and in a GPS-denied
  zone dead reckoning from the last fix with the INS increments, its standard
  deviation growing 5% of the distance flown;
* ``skf``: feng2019's switching Kalman filter per vehicle
  (:func:`gcs.core.navigation.skf.nav_update`): INS eq. (1), the GPS fix with the
  GNSS velocity and heading when there is one, and map observations against the
  segments of the vehicle's commanded path (the previous step's plan, rolled out
  from the position the vehicle believed then, :data:`ROUTE_SUBSTEPS` points a step,
  placed as uncertainly as that belief was);
  ``skf_no_cov`` without giving its covariance to the target filter, ``skf_no_route``
  without the route.

Each step a vehicle's GPS (the simulator's :class:`~sim_vehicles.truth.gps.GpsModel`,
with the scenario's ``gps_denied`` polygons) is read and its INS
(:class:`~sim_vehicles.truth.ins.InsModel`) gives the increments of the arc it flew.
In process the vehicles fly their commanded turn rates exactly (no wind, no
autopilot lag), so the commanded path is where they really go relative to where
they believed they were: the map observation is the optimistic case of what the
daemon will see.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario
from gcs.core.geometry import wrap_angle
from gcs.core.kinematics import VehicleState, rollout
from gcs.core.navigation.route import TransitionModel, route_segments
from gcs.core.navigation.skf import NavEstimate, NavMeasurement, NavParams, initial, nav_update, position
from sim_vehicles.scene import simple_navigation
from sim_vehicles.truth.gps import GpsModel, GpsState
from sim_vehicles.truth.ins import InsModel

__all__ = ["NAVIGATION_MODES", "ROUTE_SUBSTEPS", "FleetNavigation"]

INITIAL_HEADING_STD_RAD = 0.02
"""The SKF's prior heading spread at the start (which is the true heading)."""
NAVIGATION_MODES = ("perfect", "raw_gps", "raw_gps_std", "skf", "skf_no_cov", "skf_no_route")
ROUTE_SUBSTEPS = 4
"""Points per plan step of the commanded path given to the SKF as its route: the arcs flown,
not 25 m chords whose headings are off by half a step's turn (0.1 rad at 0.2 rad/s)."""
NS_PER_S = 1_000_000_000


@dataclass
class FleetNavigation:
    """Every vehicle's GPS, INS and navigation of one kind (mutable: the loop advances it).

    Build it with :meth:`start`; per step call :meth:`fly` after the truth moved,
    read :meth:`believed` and :meth:`covariance`, and give the plan to :meth:`commanded`.
    """

    mode: str
    scenario: Scenario
    gps_model: GpsModel
    ins_model: InsModel
    params: NavParams
    rngs: list[np.random.Generator]
    gps_states: list[GpsState]
    fixes: NDArray[np.bool_]
    believed_xyz: NDArray[np.float64]
    believed_heading: NDArray[np.float64]
    std_m: NDArray[np.float64]
    estimates: list[NavEstimate | None]
    routes: list[tuple] = field(default_factory=list)
    route_covs: list[NDArray[np.float64] | None] = field(default_factory=list)

    @classmethod
    def start(cls, mode: str, scenario: Scenario, seed: int, truth: VehicleState) -> FleetNavigation:
        """Every vehicle at its true start, with a first GPS reading (streams ``[seed, 10 + i]``)."""
        if mode not in NAVIGATION_MODES:
            raise ValueError(f"unknown navigation {mode!r}; expected one of {', '.join(NAVIGATION_MODES)}")
        gps_model = GpsModel.from_scenario(scenario)
        rngs = [np.random.default_rng([seed, 10 + i]) for i in range(len(truth))]
        states, fixes, std = [], [], []
        xyz = truth.xyz.copy()  # every navigation starts at the truth, as the simulated vehicles' does
        for i, rng in enumerate(rngs):
            state = gps_model.start(rng)
            state, reading = gps_model.read(state, xyz[i], 0.0, rng)
            states.append(state)
            fixes.append(reading.position_enu_m is not None)
            std.append(reading.horizontal_std_m)
        # Along the commanded path, where the vehicle is is known to about one step's flight, not to a sub-step.
        # Every navigation starts at the true pose; the SKF is told its heading is good to a compass's
        # INITIAL_HEADING_STD_RAD, not its default meant for a start from a GPS course.
        # The commanded path is laid out afresh every step, so its segment keys restart: no stay/advance
        # topology between one step's modes and the next (with it, "advance" pushed the estimate ahead).
        params = replace(NavParams.from_scenario(scenario), initial_heading_std_rad=INITIAL_HEADING_STD_RAD,
                         map_along_std_m=float(truth.speed.min() * scenario.time.step_s),
                         transitions=TransitionModel(stay=1.0, advance=1.0, jump=1.0))
        estimates = [initial(params, 0, xyz[i, :2], std[i], float(truth.heading[i]),
                             truth.speed[i] * np.array([math.cos(truth.heading[i]), math.sin(truth.heading[i])]))
                     if mode.startswith("skf") else None for i in range(len(truth))]
        return cls(mode, scenario, gps_model, InsModel(scenario.simulation.ins), params, rngs, states,
                   np.array(fixes), xyz, truth.heading.copy(), np.array(std), estimates, [() for _ in rngs],
                   [None for _ in rngs])

    def fly(self, before: VehicleState, after: VehicleState, dt: float, stamp_ns: int) -> None:
        """The vehicles flew from ``before`` to ``after`` in ``dt`` seconds: read INS and GPS, navigate."""
        for i, rng in enumerate(self.rngs):
            turn = wrap_angle(after.heading[i] - before.heading[i])
            distance, measured_turn = self.ins_model.increment(float(np.hypot(*(after.xy[i] - before.xy[i]))), turn,
                                                               dt, rng)
            self.gps_states[i], reading = self.gps_model.read(self.gps_states[i], after.xyz[i], dt, rng)
            self.fixes[i] = reading.position_enu_m is not None
            if self.mode == "perfect":
                self.believed_xyz[i], self.believed_heading[i] = after.xyz[i], after.heading[i]
            elif self.mode.startswith("raw_gps"):
                xyz, heading, self.std_m[i] = simple_navigation(self.believed_xyz[i], self.believed_heading[i],
                                                                self.std_m[i], reading, float(after.heading[i]),
                                                                float(after.altitude[i]), distance, measured_turn)
                self.believed_xyz[i], self.believed_heading[i] = xyz, wrap_angle(heading)
            else:
                fix = reading.position_enu_m
                velocity = after.speed[i] * np.array([math.cos(after.heading[i]), math.sin(after.heading[i])])
                measurement = NavMeasurement(
                    stamp_ns, ins=(distance, measured_turn, dt),
                    gps_xy=None if fix is None else fix[:2], gps_std_m=None if fix is None else reading.horizontal_std_m,
                    velocity_xy=None if fix is None else velocity,  # GNSS velocity and compass with a fix, as the simulator
                    heading_rad=None if fix is None else float(after.heading[i]))
                self.estimates[i] = nav_update(self.params, self.estimates[i], measurement, self.routes[i],
                                               self.route_covs[i])
                xy, _ = position(self.estimates[i])
                self.believed_xyz[i] = (xy[0], xy[1], after.altitude[i])
                self.believed_heading[i] = self.estimates[i].mean[2]

    def believed(self, truth: VehicleState) -> VehicleState:
        """The planner's view: believed positions and headings, the true speeds and altitudes."""
        return VehicleState(self.believed_xyz[:, :2].copy(), self.believed_heading.copy(), truth.speed, truth.altitude)

    def covariance(self, vehicle: int) -> NDArray[np.float64] | None:
        """The (2, 2) covariance the target filter gets with vehicle ``vehicle``'s detections."""
        if self.mode in ("perfect", "raw_gps", "skf_no_cov"):
            return None
        if self.mode == "raw_gps_std":
            return np.eye(2) * self.std_m[vehicle] ** 2
        return position(self.estimates[vehicle])[1]

    def commanded(self, believed: VehicleState, controls: NDArray[np.float64], dt: float,
                  max_turn_rate: NDArray[np.float64]) -> None:
        """The plan (V, T) the vehicles were just given: each one's path from where it believed it was."""
        if self.mode == "skf_no_route":
            return
        n = ROUTE_SUBSTEPS
        xy, _ = rollout(believed, np.repeat(controls, n, axis=1), dt / n, max_turn_rate, headings=False)
        self.routes = [route_segments(np.vstack([believed.xy[i], xy[i]])) for i in range(len(believed))]
        # The path is laid out from the belief: as uncertain as the belief was (nav_update's route_cov).
        self.route_covs = [None if e is None else e.cov[:3, :3].copy() for e in self.estimates]

    def errors_m(self, truth: VehicleState) -> NDArray[np.float64]:
        """Horizontal navigation error of every vehicle (V,), metres."""
        return np.hypot(*(self.believed_xyz[:, :2] - truth.xy).T)
