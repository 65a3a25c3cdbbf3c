"""The daemon's steering flown by the simulated autopilots, in one process: closed-loop flights and step responses.

:func:`fly` runs one closed loop, deterministic for a seed. The scene
(:class:`sim_vehicles.scene.Scene`: airframes, target, sensors, city) flies
each vehicle under its autopilot personality (:mod:`sim_vehicles.personalities`),
and the ground station's side is the daemon's own code: telemetry through
:func:`~gcs.adapters.mavlink_link.update_from_message`, the steering along the
planned paths (:func:`gcs.core.steering.follow`, :data:`STEER_RATE_HZ` a
second), what is sent and when (:func:`~gcs.adapters.mavlink_commands.due_actions`),
and every decision: the daemon's engine (:class:`gcs.engine.engine.Engine`) takes the
scene's liveliness, reports, nav reports and truth as the daemon receives them (encoded as
on the wire), releases and fuses the steps, hands over the plans and gives each vehicle
the path to steer along, fed and carried out by the benchmarks' shell of the engine
(:class:`benchmarks.closed_loop.EngineLoop`). Every MAVLink message is packed and parsed as on the
wire. What is not the daemon's: no sockets, no planner process (each job is planned at once, without
deadline: :func:`gcs.engine.plan_at_once.plan_at_once`), no clock (simulation time is the
engine's). Who saw the target at each step and the fused position's error against the
truth are the engine's step records.

Steering encodings (``steering``): ``lead`` is the daemon's; ``pursuit``
commands the course toward the planned position :data:`PURSUIT_STEPS` steps on,
with no lead, for comparison.

:func:`step_response` and :func:`identify` measure a personality's course loop
(:class:`gcs.core.steering.CourseLoop`) from course steps commanded with
GUIDED_CHANGE_HEADING, as ``gcs-bench autopilots --identify`` prints them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import msgspec
import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm
from scipy.optimize import least_squares, minimize_scalar

from gcs.adapters.mavlink_commands import LATERAL_ACCEL_MARGIN, SendMemory, due_actions
from gcs.adapters.mavlink_link import HeadingCommand, VehicleLink, steering_command, update_from_message
from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, GCS_SYSID, mavlink, ned_yaw_from_enu_heading
from gcs.config import Scenario
from gcs.config.simulation import AirframeConfig
from gcs.core.geometry import LocalFrame, wrap_angle
from gcs.core.steering import IDENTIFIED_AT_TURN_RATE_RAD_S, SAMPLES_PER_STEP, CourseLoop, PlannedPath, course_loop
from gcs.core.world import World
from benchmarks.closed_loop import EngineLoop
from benchmarks.course_following import SteeringSample
from gcs.engine.records import step_error_m
from gcs.engine.engine import EngineOptions
from protocols.keys import nav_key, report_key, truth_key
from sim_vehicles.personalities import make_autopilot
from sim_vehicles.scene import Scene
from sim_vehicles.truth.fixed_wing import Airframe, AirframeState

__all__ = ["FlightRecord", "STEERINGS", "fit_course_loop", "fit_turn_efficiency", "fly", "identify", "step_response",
           "with_autopilot"]

STEER_RATE_HZ = 4.0
"""The daemon's steering rate (:data:`gcs.engine.memory.STEER_RATE_HZ`), per second of vehicle time."""
STREAM_RATE_HZ = 5.0
"""The telemetry rate the daemon asks for (:data:`gcs.adapters.mavlink_commands.DEFAULT_STREAM_RATE_HZ`)."""
SETTLE_S = 10.0
SMALL_STEP_DEG, LARGE_STEP_DEG = 10.0, 90.0
"""The course steps a course loop is identified from (the same for a personality and for ArduPlane SITL)."""
HELD_LEADS_DEG = (10.0, 20.0)
"""The leads of the turns held with a constant lead that give the loop's gain; below the bank limit."""
HELD_S = 8.0
"""A held turn's steady rate is its mean over its last this many seconds (of 20)."""
"""Course errors are counted from this long after the first plan."""
PURSUIT_STEPS = 4
STEERINGS = ("lead", "pursuit")
LINK_TIMEOUT_S = 5.0
NS_PER_S = 1_000_000_000


def with_autopilot(scenario: Scenario, personality: str) -> Scenario:
    """The scenario with every vehicle flying ``personality``."""
    vehicles = [msgspec.structs.replace(v, autopilot=None) for v in scenario.vehicles]
    simulation = msgspec.structs.replace(scenario.simulation, autopilot=personality)
    return msgspec.structs.replace(scenario, vehicles=vehicles, simulation=simulation)


@dataclass
class FlightRecord:
    """One flight: who saw the target at each decision step (steps, V), the fused position error (steps,; with
    ``[multitarget]`` the step's GOSPA against every target, :func:`gcs.engine.records.step_error_m`), each
    vehicle's :class:`~benchmarks.course_following.SteeringSample` at each steering instant after
    :data:`SETTLE_S`, and the turn-rate limit the vehicles were planned at."""

    personality: str
    steering: str
    seed: int
    seen: NDArray[np.bool_]
    errors_m: NDArray[np.float64]
    steering_samples: list[list[SteeringSample]] = field(default_factory=list)
    max_turn_rate_rad_s: float = IDENTIFIED_AT_TURN_RATE_RAD_S

    @property
    def course_errors_rad(self) -> list[list[float]]:
        return [[s.course_error_rad for s in samples] for samples in self.steering_samples]

    @property
    def seen_any(self) -> int:
        return int(self.seen.any(axis=1).sum())

    @property
    def seen_per_uav(self) -> list[int]:
        return [int(x) for x in self.seen.sum(axis=0)]

    @property
    def course_error_deg_median(self) -> float:
        pooled = np.abs(np.concatenate([np.asarray(e) for e in self.course_errors_rad]))
        return float(np.degrees(np.median(pooled))) if pooled.size else float("nan")


class _Wire:
    """Packs a message with its sender's encoder and parses it as the receiver would."""

    def __init__(self) -> None:
        self.parser = mavlink.MAVLink(None)

    def __call__(self, message, encoder: mavlink.MAVLink):
        parsed = self.parser.parse_buffer(message.pack(encoder))
        assert parsed is not None and len(parsed) == 1
        return parsed[0]


@dataclass
class _Vehicle:
    """One vehicle as both sides see it: its autopilot and encoder, and the daemon's link and send memory."""

    autopilot: object
    encoder: mavlink.MAVLink
    link: VehicleLink
    loop: CourseLoop
    memory: SendMemory = field(default_factory=SendMemory)
    path: PlannedPath | None = None
    samples: list[SteeringSample] = field(default_factory=list)


def _steer(vehicle: _Vehicle, steering: str, now: float) -> HeadingCommand | None:
    """The command the daemon's steering (``lead``) or the pursuit of a point on the plan gives at ``now``.

    ``lead`` follows the path from the latest telemetry, aged as the daemon ages it (``now`` less the
    time the position was heard, :meth:`gcs.daemon.app.Daemon._steer`)."""
    path, link = vehicle.path, vehicle.link
    if path is None:
        return None
    if steering == "lead":
        return steering_command(link, path, vehicle.loop, 1.0 / STEER_RATE_HZ, link.position_age_s(now))
    if link.position_enu_m is None or link.course_rad() is None or link.ground_speed_mps() is None:
        return None
    aim = path.points[min(PURSUIT_STEPS * SAMPLES_PER_STEP, len(path.points) - 1)]
    heading = math.atan2(aim[1] - link.position_enu_m[1], aim[0] - link.position_enu_m[0])
    return HeadingCommand(heading, path.altitude_m, path.airspeed_mps)


def fly(scenario: Scenario, world: World, personality: str, seed: int, duration_s: float | None = None,
        steering: str = "lead", planner: str | None = None) -> FlightRecord:
    """One closed-loop flight of the scenario's vehicles under ``personality`` (module docstring)."""
    if steering not in STEERINGS:
        raise ValueError(f"unknown steering {steering!r}; expected one of {', '.join(STEERINGS)}")
    scenario = with_autopilot(scenario, personality)
    sim = scenario.simulation
    dt, step_s = sim.physics_step_s, scenario.time.step_s
    steps = int(round((duration_s or scenario.time.duration_s) / step_s))
    per_step = int(round(step_s / dt))
    per_nav = max(1, int(round(1.0 / (sim.nav_rate_hz * dt))))
    per_steer = max(1, int(round(1.0 / (STEER_RATE_HZ * dt))))
    per_heartbeat = int(round(1.0 / dt))
    scene = Scene(scenario, world, seed)
    loop = EngineLoop(scenario, world, np.random.default_rng([seed, 3]), EngineOptions(planner=planner), clock=None)
    engine = loop.engine
    roster = engine.roster
    gcs = mavlink.MAVLink(None, srcSystem=GCS_SYSID, srcComponent=mavlink.MAV_COMP_ID_MISSIONPLANNER)
    wire = _Wire()
    vehicles: dict[str, _Vehicle] = {}
    for cfg in scenario.vehicles:
        encoder = mavlink.MAVLink(None, srcSystem=cfg.sysid, srcComponent=1)
        autopilot = make_autopilot(personality, cfg.sysid, scene.frame, sim.airframe, cfg.speed_mps, cfg.altitude_m,
                                   encoder, sim.telemetry_rate_hz)
        autopilot.start(scene.vehicles[cfg.id].state)
        vehicles[cfg.id] = _Vehicle(autopilot, encoder, VehicleLink(cfg.id, cfg.sysid), course_loop(personality))
    loop.declare(vehicles, 0.0)  # as each simulated vehicle's token

    first_plan_s: float | None = None
    for tick in range(steps * per_step):
        now = scene.elapsed_s
        for vid, vehicle in vehicles.items():
            truth = scene.vehicles[vid]
            outgoing = [vehicle.autopilot.heartbeat()] if tick % per_heartbeat == 0 else []
            outgoing += vehicle.autopilot.streams(now, truth.state, truth.gps, scene.wind)
            for message in outgoing:
                update_from_message(vehicle.link, wire(message, vehicle.encoder), now, scene.frame)
        if tick % per_nav == 0:
            for vid in roster:
                loop.send(nav_key(vid), scene.nav_report(vid), now)
        if tick % per_step == 0:
            for vid in roster:
                loop.send(report_key(vid), scene.sensor_report(vid), now)
            for truth in scene.truths():
                loop.send(truth_key(truth.target_id), truth, now)
        loop.tick(now)
        if first_plan_s is None and engine.loop.paths:
            first_plan_s = now
        if tick % per_steer == 0:
            paths = dict(engine.steer())
            for vid, vehicle in vehicles.items():
                vehicle.path = paths.get(vid)
                command = _steer(vehicle, steering, now)
                if command is not None:
                    vehicle.link.command = command
                if vehicle.path is not None and first_plan_s is not None and now - first_plan_s >= SETTLE_S:
                    state = scene.vehicles[vid].state
                    index = vehicle.path.nearest(state.position_enu_m)
                    course = state.course_rad(scene.wind)
                    vehicle.samples.append(SteeringSample(now, course, wrap_angle(course - vehicle.path.courses[index]),
                                                          float(vehicle.path.turn_rates[index])))
        for vid, vehicle in vehicles.items():
            truth = scene.vehicles[vid]
            actions, vehicle.memory = due_actions(
                scene.frame, vehicle.link, vehicle.memory, now, max_turn_rate_rad_s=truth.config.max_turn_rate_rad_s,
                carrot_period_s=1.0 / STEER_RATE_HZ, link_timeout_s=LINK_TIMEOUT_S, stream_rate_hz=STREAM_RATE_HZ)
            for action in actions:
                replies = vehicle.autopilot.handle(wire(action.encode(gcs, vehicle.link.sysid), gcs), now, truth.state)
                for reply in replies:
                    update_from_message(vehicle.link, wire(reply, vehicle.encoder), now, scene.frame)
            vehicle.autopilot.update(now, truth.state, scene.wind)
        scene.advance(dt, {vid: v.autopilot.guidance for vid, v in vehicles.items() if v.autopilot.guidance is not None})
    loop.finish(scene.elapsed_s)  # the last steps
    seen = np.zeros((steps, len(roster)), dtype=bool)
    errors = np.full(steps, np.nan)
    for record in engine.records:
        seen[record.index] = [record.seen[v] for v in roster]
        error = step_error_m(record)
        errors[record.index] = np.nan if error is None else error
    return FlightRecord(personality, steering, seed, seen, errors, [v.samples for v in vehicles.values()],
                        float(np.min(engine.tracker.max_turn_rate)))


# ------------------------------------------------------------------ step responses


def step_response(personality: str, step_deg: float, seconds: float = 20.0, airspeed_mps: float = 25.0,
                  max_turn_rate_rad_s: float = IDENTIFIED_AT_TURN_RATE_RAD_S, dt: float = 0.05,
                  turn_efficiency: float | None = None, hold: bool = False
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Times (s) and turn rates (rad/s) after GUIDED_CHANGE_HEADING turns the course ``step_deg`` to the left,
    from straight flight east in GUIDED, with the lateral acceleration limit the daemon sends
    (``margin V omega_max``); ``turn_efficiency`` replaces the ``arduplane`` personality's. With ``hold`` the
    course asked is ``step_deg`` ahead of the vehicle's, sent again :data:`STEER_RATE_HZ` times a second (a
    turn held with a constant lead, as the daemon's steering holds one)."""
    frame = LocalFrame(47.0, 8.0, 400.0)
    config = AirframeConfig()
    gcs = mavlink.MAVLink(None, srcSystem=GCS_SYSID, srcComponent=mavlink.MAV_COMP_ID_MISSIONPLANNER)
    encoder = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    wire = _Wire()
    autopilot = make_autopilot(personality, 1, frame, config, airspeed_mps, 200.0, encoder)
    if turn_efficiency is not None:
        autopilot.turn_efficiency = turn_efficiency
    airframe = Airframe(config, max_turn_rate_rad_s, (0.0, 0.0))
    state = AirframeState(np.array([0.0, 0.0, 200.0]), heading_rad=0.0, roll_rad=0.0, airspeed_mps=airspeed_mps)
    autopilot.start(state)

    def send(message) -> None:
        autopilot.handle(wire(message, gcs), 0.0, state)

    send(gcs.command_long_encode(1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                 ARDUPLANE_MODES["GUIDED"], 0, 0, 0, 0, 0))
    def course(enu_rad: float) -> None:
        course_ned = math.degrees(ned_yaw_from_enu_heading(enu_rad)) % 360.0
        send(gcs.command_int_encode(1, 1, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, 0, 0,
                                    mavlink.HEADING_TYPE_COURSE_OVER_GROUND, course_ned,
                                    LATERAL_ACCEL_MARGIN * airspeed_mps * max_turn_rate_rad_s, 0, 0, 0, 0))

    course(math.radians(step_deg))
    per_command = int(round(1.0 / (STEER_RATE_HZ * dt)))
    times, rates = [], []
    t = 0.0
    for tick in range(int(round(seconds / dt))):
        if hold and tick and tick % per_command == 0:
            course(state.course_rad((0.0, 0.0)) + math.radians(step_deg))
        autopilot.update(t, state, (0.0, 0.0))
        state = airframe.step(state, autopilot.guidance, dt)
        t = round(t + dt, 9)
        times.append(t)
        rates.append(state.turn_rate_rad_s)
    return np.array(times), np.array(rates)


def _model_rates(gain: float, lag: float, step_rad: float, times: NDArray[np.float64], dt: float
                 ) -> NDArray[np.float64]:
    """The turn rates of ``tau omega' = K e - omega``, ``e' = -omega`` from ``e = step``, exactly discretised."""
    a = np.array([[0.0, -1.0], [gain / lag, -1.0 / lag]])  # state (e, omega)
    transition = expm(a * dt)
    x = np.array([step_rad, 0.0])
    out = []
    for _ in times:
        x = transition @ x
        out.append(x[1])
    return np.array(out)


def held_rate(rates: NDArray[np.float64], times: NDArray[np.float64]) -> float:
    """The steady turn rate of a turn held with a constant lead: the mean over its last :data:`HELD_S` seconds."""
    return float(np.mean(rates[times > times[-1] - HELD_S]))


def fit_course_loop(times: NDArray[np.float64], small: NDArray[np.float64], large: NDArray[np.float64],
                    airspeed_mps: float, bank_to_turn: bool, held: dict[float, float] | None = None) -> CourseLoop:
    """The course loop of step responses, every ``times[0]`` s: ``K`` and ``tau`` fitted (least squares on the turn
    rate) to the :data:`SMALL_STEP_DEG` step's rates ``small``, and the largest turn rate the 90th percentile of the
    :data:`LARGE_STEP_DEG` step's rates ``large`` (its plateau at the bank limit).

    With ``held`` (lead in degrees -> steady rate in rad/s of turns held with a constant lead sent again
    :data:`STEER_RATE_HZ` times a second), ``K`` is theirs instead, and ``tau`` is fitted with it: a
    bank-to-turn loop's first second after a step turns faster than the turn it settles into (the bank's
    transient), and the daemon's steering holds a lead for as long as a turn lasts. A lead ``l`` held so
    turns at ``omega = K_h l`` (least squares through the origin); the steering's lead is
    ``omega / K + omega T / 2`` (:func:`gcs.core.steering.follow`, ``T`` the steering period), so
    ``1 / K = 1 / K_h - T / 2``."""
    dt = float(times[0])
    gain: float | None = None
    if held is not None:
        leads = np.radians(list(held))
        held_gain = float(np.dot(leads, list(held.values())) / np.dot(leads, leads))
        gain = 1.0 / (1.0 / held_gain - 0.5 / STEER_RATE_HZ)

    def residuals(x: NDArray[np.float64]) -> NDArray[np.float64]:
        k, lag = (x[0], x[1]) if gain is None else (gain, x[0])
        return _model_rates(k, lag, math.radians(SMALL_STEP_DEG), times, dt) - small

    start, low, high = ([0.5, 0.5], [1e-3, 1e-3], [10.0, 10.0]) if gain is None else ([0.5], [1e-3], [10.0])
    fit = least_squares(residuals, x0=start, bounds=(low, high))
    return CourseLoop(gain_per_s=float(fit.x[0]) if gain is None else gain, lag_s=float(fit.x[-1]),
                      max_turn_rate_rad_s=float(np.percentile(large, 90)), airspeed_mps=airspeed_mps,
                      bank_to_turn=bank_to_turn)


def identify(personality: str, airspeed_mps: float = 25.0, turn_efficiency: float | None = None) -> CourseLoop:
    """The personality's course loop (:func:`fit_course_loop` on its :func:`step_response` to course steps of
    :data:`SMALL_STEP_DEG` and :data:`LARGE_STEP_DEG`; for a bank-to-turn loop, ArduPlane's, also to turns held
    with the leads :data:`HELD_LEADS_DEG`, as the real ArduPlane's is identified)."""
    times, small = step_response(personality, SMALL_STEP_DEG, airspeed_mps=airspeed_mps,
                                 turn_efficiency=turn_efficiency)
    _, large = step_response(personality, LARGE_STEP_DEG, airspeed_mps=airspeed_mps, turn_efficiency=turn_efficiency)
    bank_to_turn = course_loop(personality).bank_to_turn
    held = None
    if bank_to_turn:
        held = {}
        for lead in HELD_LEADS_DEG:
            held_times, rates = step_response(personality, lead, airspeed_mps=airspeed_mps,
                                              turn_efficiency=turn_efficiency, hold=True)
            held[lead] = held_rate(rates, held_times)
    return fit_course_loop(times, small, large, airspeed_mps, bank_to_turn, held)


def fit_turn_efficiency(real: CourseLoop, airspeed_mps: float = 25.0) -> float:
    """The ``arduplane`` personality's turn efficiency (:data:`sim_vehicles.arduplane.TURN_EFFICIENCY`) whose
    identified loop is nearest the real ArduPlane's ``real``: least squares on the relative errors of the gain
    ``K`` and of the largest turn rate (the roll lag is the scenario airframe's, not fitted)."""

    def misfit(efficiency: float) -> float:
        loop = identify("arduplane", airspeed_mps, turn_efficiency=efficiency)
        return ((loop.gain_per_s / real.gain_per_s - 1.0) ** 2
                + (loop.max_turn_rate_rad_s / real.max_turn_rate_rad_s - 1.0) ** 2)

    return float(minimize_scalar(misfit, bounds=(0.3, 1.0), method="bounded", options={"xatol": 1e-3}).x)
