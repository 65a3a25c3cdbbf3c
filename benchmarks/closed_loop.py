"""The closed loop of every in-process benchmark: a simulated scene feeds the ground station's engine, and the
engine's plans fly the vehicles.

The ground station's side is the daemon's engine (:class:`gcs.engine.engine.Engine`, docs/design.md),
fed as ``gcs replay --process`` feeds it a recording: every message the simulated vehicles send (their
liveliness, ``NavReport``, ``SensorReport`` and the targets' ``TargetTruth``), encoded and decoded as on
the wire, goes in as an :class:`~gcs.engine.events.Arrived` input received at its stamp. The clock is the
simulation's: it advances in ticks of :data:`SUBSTEP_S`, and at each tick a :class:`~gcs.engine.events.Tick`
releases the decision steps that are ready (a step is complete once every vehicle alive has reported for
it; in process every report arrives at its own tick, so there is no reorder window to wait for,
:data:`IN_PROCESS`) and a
:class:`~gcs.engine.events.PlannerFree` hands the newest fused step to the planner, which plans it at once
with no deadline (:func:`gcs.engine.plan_at_once.plan_at_once`): the figures depend on the seeds alone,
never on the machine or on the process a run is in. The paths of the finished plans
(:meth:`Engine.steer <gcs.engine.engine.Engine.steer>`) fly the vehicles.

:class:`EngineLoop` is that shell; :class:`IdealAirframes` flies the vehicles as wang2012 eq. (1) does: each
holds the turn rate its planned path gives for the moment (the path's own turn rates, each held one
decision step, exact arcs), so a plan made at step ``k`` is flown from its stamp as the paper's loop flies
it. A vehicle the engine does not steer (before its first plan, after its plan's horizon, or given back
after the target was lost: :class:`~gcs.engine.events.LetGo`) does what an autopilot left alone does: it
holds its course until it has been steered, then loiters (counter-clockwise, the airframe's loiter radius)
about where the steering stopped, or about a home circle when the benchmark gives one. :func:`fly` runs the
loop: the scene's messages at each tick, the tick, the flight to the next.
"""

from __future__ import annotations

import math
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario
from gcs.core.geometry import wrap_angle
from gcs.core.kinematics import VehicleState, step_vehicles
from gcs.core.planners.baselines import orbit_heading
from gcs.core.steering import PlannedPath
from gcs.core.world import World
from gcs.engine.engine import Engine, EngineOptions
from gcs.engine.events import (Arrived, LetGo, PlannerFree, PublishMemberTracks, PublishPlan, PublishTrack, SubmitPlan,
                               Tick)
from gcs.engine.plan_at_once import JobPlanner, plan_at_once
from gcs.engine.plan_jobs import plan_job
from gcs.engine.steps import HOLD_WAITS
from protocols.codec import encode
from protocols.keys import alive_key
from protocols.messages import PlanCommand, TrackEstimate

__all__ = ["SUBSTEP_S", "NS_PER_S", "IN_PROCESS", "Loiter", "EngineLoop", "IdealAirframes", "SimulatedScene", "fly",
           "fly_step"]

SUBSTEP_S = 0.1
"""The simulated clock's tick: inputs are handed over, steps released and the vehicles flown this often."""
NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class Loiter:
    """A circle a vehicle loiters on when it is not steered: centre (x, y) and radius, metres (counter-clockwise)."""

    centre: tuple[float, float]
    radius_m: float


IN_PROCESS = EngineOptions(plan_every_step=True, max_wait_s=0.0, autopilot_turn_rates=False)
"""The engine's options in process: every fused step planned, and no reorder window (``max_wait_s`` 0), so the
first step is planned at its stamp as every later one is, as wang2012's loop does."""

class EngineLoop:
    """The engine with a shell that carries out its actions at once (module docstring).

    Kept for the benchmark: every published track and plan by its stamp (:attr:`tracks`, :attr:`commands`), a
    federation member's messages in order (:attr:`member_tracks`),
    how long each plan took
    (:attr:`plan_seconds`, by the stamp of the step it was planned for) and each tick (:attr:`tick_seconds`,
    by the decision step the clock was in), the vehicles given back (:attr:`let_go`).
    """

    def __init__(self, scenario: Scenario, world: World | None, seed_rng: np.random.Generator,
                 options: EngineOptions | None = None, planner: JobPlanner = plan_job, plans: bool = True,
                 clock: Callable[[], float] | None = time.perf_counter) -> None:
        self.engine = Engine(scenario, world, options or IN_PROCESS)
        self.rng, self.planner, self.plans, self.clock = seed_rng, planner, plans, clock
        self.step_s = scenario.time.step_s
        self.tracks: dict[int, list[TrackEstimate]] = defaultdict(list)
        self.commands: dict[int, list[PlanCommand]] = defaultdict(list)
        self.plan_seconds: dict[int, float] = {}
        self.tick_seconds: dict[int, float] = defaultdict(float)
        self.let_go: list[tuple[float, tuple[str, ...]]] = []
        self.member_tracks: list[PublishMemberTracks] = []
        self._now_s = 0.0

    def declare(self, vehicle_ids: Iterable[str], now_s: float) -> None:
        """Each vehicle's liveliness token, declared before it sends anything."""
        for vehicle_id in vehicle_ids:
            self.engine.feed(Arrived("alive", alive_key(vehicle_id), b"", "", round(now_s * NS_PER_S), now_s))

    def send(self, key: str, message, now_s: float) -> None:
        """One message as the vehicle publishes it, received at ``now_s``."""
        payload, encoding = encode(message)
        self.engine.feed(Arrived("sample", key, payload, encoding, message.stamp_ns, now_s))

    def tick(self, now_s: float) -> None:
        """The clock at ``now_s``: release and fuse the ready steps, plan the newest at once."""
        self._now_s = now_s
        started = self._time()
        self._carry_out(self.engine.feed(Tick(now_s)))
        if self.clock is not None:
            self.tick_seconds[math.floor(now_s / self.step_s + 1e-9)] += self._time() - started
        if self.plans:
            self._carry_out(self.engine.feed(PlannerFree(now_s)))

    def finish(self, now_s: float) -> None:
        """The run is over: release what is still open (past every step's deadline) and score every step."""
        self.tick(now_s + HOLD_WAITS * self.engine.options.max_wait_s + 1.0)
        self.engine.flush()

    def paths(self) -> dict[str, tuple[PlannedPath, float]]:
        """Each steered vehicle's path and the time its plan starts (its step's stamp), seconds."""
        stamps = self.engine.loop.path_stamps_ns
        return {vehicle_id: (path, stamps[vehicle_id] / NS_PER_S) for vehicle_id, path in self.engine.steer()}

    def _time(self) -> float:
        return 0.0 if self.clock is None else self.clock()

    def _carry_out(self, actions: list) -> None:
        for action in actions:
            if isinstance(action, PublishTrack):
                self.tracks[action.track.stamp_ns].append(action.track)
            elif isinstance(action, PublishPlan):
                self.commands[action.command.stamp_ns].append(action.command)
            elif isinstance(action, LetGo):
                self.let_go.append((self._now_s, action.vehicle_ids))
            elif isinstance(action, PublishMemberTracks):
                self.member_tracks.append(action)
            elif isinstance(action, SubmitPlan):
                started = self._time()
                done = plan_at_once(self.engine, action.job, self.rng, self.planner)
                if self.clock is not None:
                    self.plan_seconds[action.job.stamp_ns] = self._time() - started
                self._carry_out(done)


class IdealAirframes:
    """The vehicles of a roster flying wang2012 eq. (1): a turn rate held over each tick (module docstring)."""

    def __init__(self, roster: Sequence[str], start: VehicleState, max_turn_rate: NDArray[np.float64],
                 step_s: float, loiter_radius_m: float, homes: Sequence[Loiter | None] | None = None) -> None:
        self.roster, self.state, self.max_turn_rate, self.step_s = list(roster), start, max_turn_rate, step_s
        self.loiter_radius_m = loiter_radius_m
        self.homes: list[Loiter | None] = list(homes) if homes is not None else [None] * len(self.roster)
        self._loiter: list[Loiter | None] = list(self.homes)
        self._steered = [False] * len(self.roster)

    def turn_rates(self, now_s: float, paths: dict[str, tuple[PlannedPath, float]]) -> NDArray[np.float64]:
        """Each vehicle's turn rate now (V,): its path's, or its own when it is not steered."""
        rates = np.zeros(len(self.roster))
        for i, vehicle_id in enumerate(self.roster):
            steered = paths.get(vehicle_id)
            rate = None if steered is None else _path_rate(*steered, now_s)
            if rate is not None:
                rates[i], self._steered[i] = rate, True
                self._loiter[i] = self.homes[i]
                continue
            if self._loiter[i] is None and self._steered[i]:  # let go, or past its plan: loiter where it is
                self._loiter[i] = Loiter(tuple(self.state.xy[i]), self.loiter_radius_m)
            if self._loiter[i] is not None:
                rates[i] = self._toward(i, self._loiter[i])
        return rates

    def _toward(self, i: int, loiter: Loiter) -> float:
        """The turn rate that brings vehicle ``i`` onto its loiter circle: the circle's own rate ``V / R``
        (counter-clockwise) and the error from :func:`~gcs.core.planners.baselines.orbit_heading` closed in
        a step, as the simulated airframe's loiter law (:mod:`sim_vehicles.truth.fixed_wing`)."""
        desired = orbit_heading(self.state.xy[i:i + 1], loiter.centre, loiter.radius_m)[0]
        limit = float(self.max_turn_rate[i])
        rate = self.state.speed[i] / loiter.radius_m + wrap_angle(desired - self.state.heading[i]) / self.step_s
        return float(np.clip(rate, -limit, limit))

    def fly(self, dt: float, rates: NDArray[np.float64]) -> None:
        """Every vehicle ``dt`` seconds on its turn rate (an exact arc)."""
        self.state = step_vehicles(self.state, rates, dt, self.max_turn_rate)


def _path_rate(path: PlannedPath, start_s: float, now_s: float) -> float | None:
    """The path's turn rate at ``now_s`` (its turn rates are held from the plan's stamp); None past its end."""
    index = math.floor((now_s - start_s) / path.spacing_s + 1e-6)
    if index < 0 or index >= len(path.turn_rates) - 1:
        return None
    return float(path.turn_rates[index])


class SimulatedScene(Protocol):
    """What a benchmark simulates: the messages its vehicles send at a tick, and what their flight did."""

    def messages(self, step: int, substep: int, vehicles: VehicleState | None) -> list[tuple[str, object]]:
        """The ``(key, message)`` pairs sent at ``step``'s ``substep``-th tick (stamped at that time)."""

    def flown(self, before: VehicleState, after: VehicleState, dt: float) -> None:
        """The vehicles flew from ``before`` to ``after`` in ``dt`` seconds (navigation sensors, airspace)."""


def fly(loop: EngineLoop, scene: SimulatedScene, steps: int, airframes: IdealAirframes | None = None,
        after_tick: Callable[[int, int], None] | None = None) -> None:
    """Run ``steps`` decision steps (:func:`fly_step` each), then finish the loop."""
    for k in range(steps):
        fly_step(loop, scene, k, airframes, after_tick)
    loop.finish(steps * loop.step_s)


def fly_step(loop: EngineLoop, scene: SimulatedScene, k: int, airframes: IdealAirframes | None = None,
             after_tick: Callable[[int, int], None] | None = None) -> None:
    """Decision step ``k``: at every tick the scene's messages, the tick, then the flight to the next tick
    (``airframes`` None: the scene moves its vehicles itself). ``after_tick(step, substep)`` sees each."""
    per_step = round(loop.step_s / SUBSTEP_S)
    for sub in range(per_step):
        now = (k * per_step + sub) * SUBSTEP_S
        vehicles = None if airframes is None else airframes.state
        for key, message in scene.messages(k, sub, vehicles):
            loop.send(key, message, now)
        loop.tick(now)
        if after_tick is not None:
            after_tick(k, sub)
        if airframes is not None:
            before = airframes.state
            airframes.fly(SUBSTEP_S, airframes.turn_rates(now, loop.paths()))
            scene.flown(before, airframes.state, SUBSTEP_S)
