"""``gcs-bench federation``: several daemons, each with its team, against one central daemon that flies every UAV.

**Scene per seed** (every draw from ``numpy.random.default_rng(seed)``): the targets of
:func:`benchmarks.multitarget.make_scene` (street-following cars on the wang2012_urban city,
3 km x 3 km, a side-by-side pair among them) driving across a city divided into ``members``
vertical strips, one per member; each member's team of ``uavs_per_member`` UAVs starts on a ring
about its strip's centre and loiters there when not steered. The sensors reach ``range_m`` (1 km by
default; the scenario's 5 km would let every team see the whole city).

**Federation**: one engine per member (:class:`gcs.engine.engine.Engine` with
:class:`~gcs.engine.federation.FederationOptions`, its [multitarget] JPDA), fed only its own UAVs'
messages; each member's :class:`~protocols.federation.MemberTracks` goes, encoded as on the wire,
to every other live member one tick (0.1 s) after it was published, and a killed member's
liveliness token is withdrawn at once. **Central**: one engine with every UAV, on the same seed.
The UAVs fly the plans (:class:`~benchmarks.closed_loop.IdealAirframes`); the scans come from where
they are (:class:`~benchmarks.many_targets_loop.SharingScene`, draws from ``default_rng([seed, 1])``).

**Scores** after the warm-up, against the truths:

* **GOSPA** (c = 100 m, p = 2, alpha = 2) of each member's picture (every target held by any member,
  fused), averaged over the live members; of the confirmed tracks for the central daemon;
* **id changes** per target: the ids the estimates assigned to it (GOSPA's assignment) carried, less
  one (a target tracked under one id throughout has none), the largest over the targets (and the
  members); and the **id swaps** (an id that was another target's, :func:`gcs.core.metrics.track_scores`),
  which the side-by-side pair causes in any tracker;
* **NEES inside its band**: the steps whose position NEES averaged over the assigned targets
  (M of them) lies inside the two-sided 95% band of ``chi2(2M) / M``; and the mean NEES of the
  estimates fused from two or more members' tracks (2, the dimension, when the fusion is consistent;
  more when it counts shared information twice);
* **hand-over** time: from a car crossing into another member's strip, tracked before under a
  global id, to that member's own track carrying the same id with its own detection (and, apart, to
  that member planning for it under that id);
* **take-up** (with ``--kill``): from a member's death to another member planning for (claiming)
  each target the dead one held, and to another member holding a track on it;
* **bytes per second** each member publishes, and the **decision time** (scan and plan) per step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import msgspec
import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from benchmarks import multitarget as mt
from benchmarks.closed_loop import NS_PER_S, SUBSTEP_S, EngineLoop, IdealAirframes, Loiter
from benchmarks.many_targets_loop import SharingScene, many_target_scenario
from benchmarks.sharing import FORGET_S, STARVATION_S
from gcs.config import Scenario
from gcs.core.kinematics import VehicleState
from gcs.core.metrics import StepTracks, gospa, track_scores
from gcs.core.world import World
from gcs.engine.engine import EngineOptions
from gcs.engine.federation import FederationOptions, PublishMemberTracks
from gcs.engine.steps import HOLD_WAITS
from protocols.codec import encode
from protocols.keys import member_alive_key, member_tracks_key, parse_key

__all__ = ["FederationConfig", "RunScores", "FlownFederation", "run_federation", "score_federation", "fly_federation",
           "fly_central", "areas"]

PREFIX = "federation"
RING_M = 300.0
NEES_BAND = 0.95


@dataclass(frozen=True)
class FederationConfig:
    """One run's set-up (module docstring); ``kill``: (member index, step) of a member that dies."""

    members: int = 3
    uavs_per_member: int = 3
    scene: mt.BenchConfig = mt.BenchConfig(targets=6, steps=180)
    fusion: str = "ci"
    kill: tuple[int, int] | None = None
    range_m: float = 1000.0
    """The UAVs' sensor range: a team sees its own strip and its neighbours' edges, not the whole city."""
    tracker: str = "auto"
    """``[multitarget] kind``: ``auto`` is the daemon's default, the road tracker on a city with roads."""


@dataclass
class RunScores:
    """One run's scores (module docstring)."""

    gospa_m: float
    id_changes_max: int
    id_changes_mean: float
    nees_inside: float
    id_swaps: float = 0.0
    nees_fused_mean: float = math.nan
    """The mean position NEES of the estimates fused from two or more members' tracks (2 when consistent)."""
    decision_seconds: list[float] = field(default_factory=list)
    hand_over_s: list[float] = field(default_factory=list)
    hand_overs_missed: int = 0
    hand_over_claim_s: list[float] = field(default_factory=list)
    take_up_claim_s: list[float] = field(default_factory=list)
    take_up_held_s: list[float] = field(default_factory=list)
    bytes_per_s: list[float] = field(default_factory=list)


def areas(world: World, members: int) -> list[tuple[float, float, float, float]]:
    """The city cut in ``members`` vertical strips of equal width."""
    width, height = world.size_m
    return [(i * width / members, 0.0, (i + 1) * width / members, height) for i in range(members)]


def _team(base: Scenario, config: FederationConfig) -> Scenario:
    from benchmarks.urban import with_vehicles

    scene = config.scene
    team = with_vehicles(base, config.members * config.uavs_per_member)
    team = msgspec.structs.replace(team, sensor=msgspec.structs.replace(team.sensor, max_range_m=config.range_m))
    return many_target_scenario(team, "jpda", scene.pd, scene.clutter, len(team.vehicles), STARVATION_S, FORGET_S,
                                kind=config.tracker)


def _start(team: Scenario, config: FederationConfig, world: World) -> tuple[VehicleState, list[Loiter]]:
    """Each member's UAVs on a ring about its strip's centre, heading round it; their loiter circles."""
    xy, heading, homes = [], [], []
    for m, (x0, y0, x1, y1) in enumerate(areas(world, config.members)):
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        for i in range(config.uavs_per_member):
            angle = 2.0 * math.pi * i / config.uavs_per_member
            xy.append((cx + RING_M * math.cos(angle), cy + RING_M * math.sin(angle)))
            heading.append(angle + math.pi / 2)
            homes.append(Loiter((cx, cy), RING_M))
    speeds = np.array([v.speed_mps for v in team.vehicles])
    altitudes = np.array([v.altitude_m for v in team.vehicles])
    wrapped = np.remainder(np.array(heading) + math.pi, 2 * math.pi) - math.pi
    return VehicleState(np.array(xy), wrapped, speeds, altitudes), homes


class _Members:
    """The member engines, their rosters, and the federation traffic between them (module docstring)."""

    def __init__(self, team: Scenario, world: World, config: FederationConfig, seed: int) -> None:
        self.roster = [v.id for v in team.vehicles]
        per = config.uavs_per_member
        self.names = [f"m{m}" for m in range(config.members)]
        self.loops, self.owner = [], {}
        for m, area in enumerate(areas(world, config.members)):
            vehicles = team.vehicles[m * per:(m + 1) * per]
            scenario = msgspec.structs.replace(team, vehicles=vehicles)
            options = EngineOptions(plan_every_step=True, max_wait_s=0.0, autopilot_turn_rates=False,
                                    federation=FederationOptions(self.names[m], area, PREFIX, config.fusion,
                                                                 FORGET_S))
            self.loops.append(EngineLoop(scenario, world, np.random.default_rng([seed, 2, m]), options))
            self.owner.update({v.id: m for v in vehicles})
        self.live = [True] * config.members
        self.sent_bytes = [0] * config.members
        self._pending: list[tuple[int, str, bytes, str, int]] = []
        self._delivered = [0] * config.members

    def declare(self) -> None:
        for m, loop in enumerate(self.loops):
            loop.declare([v for v in self.roster if self.owner[v] == m], 0.0)
            for other, name in enumerate(self.names):
                if other != m:
                    loop.engine.feed(_arrived("alive", member_alive_key(name, PREFIX), b"", "", 0.0))

    def send(self, key: str, message, now_s: float) -> None:
        kind = parse_key(key)
        if kind.kind == "truth":
            for m, loop in enumerate(self.loops):
                if self.live[m]:
                    loop.send(key, message, now_s)
        elif self.live[self.owner[kind.ident]]:
            self.loops[self.owner[kind.ident]].send(key, message, now_s)

    def tick(self, now_s: float) -> None:
        """Hand over the traffic of the last tick, then tick every live member and keep what it published."""
        for m, key, payload, encoding, stamp in self._pending:
            for other, loop in enumerate(self.loops):
                if other != m and self.live[other]:
                    loop.engine.feed(_arrived("sample", key, payload, encoding, now_s, stamp))
        self._pending = []
        for m, loop in enumerate(self.loops):
            if not self.live[m]:
                continue
            loop.tick(now_s)
            for published in loop.member_tracks[self._delivered[m]:]:
                payload, encoding = encode(published.message)
                self.sent_bytes[m] += len(payload)
                self._pending.append((m, member_tracks_key(self.names[m], PREFIX), payload, encoding,
                                      published.message.stamp_ns))
            self._delivered[m] = len(loop.member_tracks)

    def kill(self, m: int, now_s: float) -> None:
        self.live[m] = False
        self._pending = [p for p in self._pending if p[0] != m]
        for other, loop in enumerate(self.loops):
            if other != m and self.live[other]:
                loop.engine.feed(_arrived("gone", member_alive_key(self.names[m], PREFIX), b"", "", now_s))

    def paths(self) -> dict:
        out = {}
        for m, loop in enumerate(self.loops):
            if self.live[m]:
                out.update(loop.paths())
        return out


def _arrived(kind: str, key: str, payload: bytes, encoding: str, now_s: float, stamp_ns: int | None = None):
    from gcs.engine.events import Arrived

    return Arrived(kind, key, payload, encoding, round(now_s * NS_PER_S) if stamp_ns is None else stamp_ns, now_s)


def _fly(sender, scene: SharingScene, airframes: IdealAirframes, steps: int, step_s: float,
         on_step=None) -> None:
    per_step = round(step_s / SUBSTEP_S)
    for k in range(steps):
        if on_step is not None:
            on_step(k)
        for sub in range(per_step):
            now = (k * per_step + sub) * SUBSTEP_S
            for key, message in scene.messages(k, sub, airframes.state):
                sender.send(key, message, now)
            sender.tick(now)
            airframes.fly(SUBSTEP_S, airframes.turn_rates(now, sender.paths()))


def _estimates_at(pictures: dict[int, PublishMemberTracks], stamp_ns: int):
    published = pictures.get(stamp_ns)
    if published is None:
        return None
    targets = published.picture.targets
    return ([t.name.global_id for t in targets], np.array([t.mean[:2] for t in targets]).reshape(-1, 2),
            np.array([t.cov[:2, :2] for t in targets]).reshape(-1, 2, 2), [len(t.holders) for t in targets])


class _Scorer:
    """GOSPA, id changes and NEES of one sequence of pictures (module docstring)."""

    def __init__(self, targets: int) -> None:
        self.gospas: list[float] = []
        self.ids: list[list[str]] = [[] for _ in range(targets)]
        self.nees_steps = 0
        self.nees_inside = 0
        self.steps: list[StepTracks] = []
        self.nees_fused: list[float] = []

    def add(self, ids: list[str], xy: NDArray[np.float64], covs: NDArray[np.float64],
            holders: list[int] | None, truth: NDArray[np.float64]) -> None:
        result = gospa(xy, truth, mt.CUTOFF_M, mt.ORDER_P)
        self.gospas.append(result.distance)
        self.steps.append(StepTracks(tuple(range(len(truth))), truth, tuple(ids), xy))
        nees = []
        for j, row in enumerate(result.assignment.tolist()):
            if row >= 0:
                if not self.ids[j] or self.ids[j][-1] != ids[row]:
                    self.ids[j].append(ids[row])
                delta = xy[row] - truth[j]
                nees.append(float(delta @ np.linalg.solve(covs[row], delta)))
                if holders is not None and holders[row] >= 2:
                    self.nees_fused.append(nees[-1])
        if nees:
            m = len(nees)
            low, high = chi2.ppf((1 - NEES_BAND) / 2, 2 * m) / m, chi2.ppf((1 + NEES_BAND) / 2, 2 * m) / m
            self.nees_steps += 1
            self.nees_inside += int(low <= np.mean(nees) <= high)

    def changes(self) -> list[int]:
        return [max(0, len(set(seq)) - 1) for seq in self.ids]

    def swaps(self) -> int:
        return track_scores(self.steps, mt.CUTOFF_M, mt.ORDER_P).id_swaps


@dataclass
class FlownFederation:
    """A federation run as flown: the members (their engines and what each published), the truths, the step, and
    the step at which a member was killed (None if none was)."""

    members: _Members
    scene: mt.Scene
    step_s: float
    killed_at: int | None

    def pictures(self) -> list[dict[int, PublishMemberTracks]]:
        """Each member's published messages (with their pictures and claims) by stamp."""
        return [{p.message.stamp_ns: p for p in loop.member_tracks} for loop in self.members.loops]


def run_federation(world: World, base: Scenario, seed: int, config: FederationConfig,
                   scene: mt.Scene | None = None) -> FlownFederation:
    """Fly one federation run on seed ``seed`` (module docstring); ``scene``: the truths to fly over instead of the
    seed's."""
    team = _team(base, config)
    members = _Members(team, world, config, seed)
    scene = scene or mt.make_scene(world, [v.altitude_m for v in team.vehicles], config.scene,
                                   np.random.default_rng(seed))
    step_s = team.time.step_s
    tracker = members.loops[0].engine.tracker
    sim = SharingScene(members.roster, world, scene, tracker.sensors[0], tracker.max_range_m, config.scene.pd,
                       config.scene.clutter, np.random.default_rng([seed, 1]), step_s)
    start, homes = _start(team, config, world)
    turn_limits = np.concatenate([loop.engine.tracker.max_turn_rate for loop in members.loops])
    airframes = IdealAirframes(members.roster, start, turn_limits, step_s, team.simulation.airframe.loiter_radius_m,
                               homes)
    members.declare()
    steps = len(scene.truth_xy)
    killed_at: list[int] = []

    def on_step(k: int) -> None:
        if config.kill is not None and k == config.kill[1]:
            members.kill(config.kill[0], k * step_s)
            killed_at.append(k)

    _fly(members, sim, airframes, steps, step_s, on_step)
    for loop in members.loops:
        loop.finish(steps * step_s + HOLD_WAITS)
    return FlownFederation(members, scene, step_s, killed_at[0] if killed_at else None)


def score_federation(flown: FlownFederation, world: World, config: FederationConfig) -> RunScores:
    """A flown federation's scores (module docstring)."""
    truth_xy, step_s, loops = flown.scene.truth_xy, flown.step_s, flown.members.loops
    steps = len(truth_xy)
    pictures = flown.pictures()
    scorers = [_Scorer(truth_xy.shape[1]) for _ in loops]
    for k in range(min(config.scene.warm_up, steps - 1), steps):
        for m, scorer in enumerate(scorers):
            estimates = _estimates_at(pictures[m], round(k * step_s * NS_PER_S))
            if estimates is not None:
                scorer.add(*estimates, truth_xy[k])
    changes = [c for s in scorers for c in s.changes()]
    scores = RunScores(
        float(np.mean([g for s in scorers for g in s.gospas])), max(changes), float(np.mean(changes)),
        sum(s.nees_inside for s in scorers) / max(1, sum(s.nees_steps for s in scorers)),
        float(np.mean([s.swaps() for s in scorers])))
    fused = [n for s in scorers for n in s.nees_fused]
    scores.nees_fused_mean = float(np.mean(fused)) if fused else math.nan
    for m, loop in enumerate(loops):
        scores.decision_seconds += _decision_seconds(loop, steps)
        scores.bytes_per_s.append(flown.members.sent_bytes[m] / (steps * step_s))
    _hand_overs(scores, pictures, world, config, truth_xy, step_s)
    if flown.killed_at is not None and config.kill is not None:
        _take_up(scores, pictures, config.kill[0], flown.killed_at, step_s, steps)
    return scores


def fly_federation(world: World, base: Scenario, seed: int, config: FederationConfig,
                   scene: mt.Scene | None = None) -> RunScores:
    """One federation run on seed ``seed`` (or over ``scene``), scored."""
    return score_federation(run_federation(world, base, seed, config, scene), world, config)


def _decision_seconds(loop: EngineLoop, steps: int) -> list[float]:
    plans = {round(stamp / NS_PER_S): seconds for stamp, seconds in loop.plan_seconds.items()}
    return [loop.tick_seconds[k] + plans.get(k, 0.0) for k in range(steps) if k in loop.tick_seconds]


def _strip(world: World, config: FederationConfig, x: float) -> int:
    width = world.size_m[0] / config.members
    return int(np.clip(x // width, 0, config.members - 1))


def _nearest_within_cutoff(items, positions, truth: NDArray[np.float64]):
    """The item whose position is nearest ``truth``, if within the GOSPA cut-off (None if none is)."""
    if not items:
        return None
    distances = [math.dist(xy, truth) for xy in positions]
    best = int(np.argmin(distances))
    return items[best] if distances[best] < mt.CUTOFF_M else None


def _own_track_on(published: PublishMemberTracks | None, truth: NDArray[np.float64]):
    """The member's own track nearest ``truth`` within the GOSPA cut-off (None if none)."""
    if published is None:
        return None
    tracks = published.message.tracks
    return _nearest_within_cutoff(tracks, [t.state[:2] for t in tracks], truth)


def _picture_id(published: PublishMemberTracks | None, truth: NDArray[np.float64]) -> str | None:
    """The global id of the member's picture's target nearest ``truth`` within the GOSPA cut-off (None if none)."""
    if published is None:
        return None
    targets = published.picture.targets
    nearest = _nearest_within_cutoff(targets, [t.mean[:2] for t in targets], truth)
    return None if nearest is None else nearest.name.global_id


def _hand_overs(scores: RunScores, pictures, world: World, config: FederationConfig, truth_xy: NDArray[np.float64],
                step_s: float) -> None:
    """Each crossing of a tracked car into another live member's strip, and how long until that member holds it."""
    steps, targets = truth_xy.shape[:2]
    stamp = [round(k * step_s * NS_PER_S) for k in range(steps)]
    for j in range(targets):
        strips = [_strip(world, config, truth_xy[k, j, 0]) for k in range(steps)]
        for k in range(max(1, config.scene.warm_up), steps):
            before, after = strips[k - 1], strips[k]
            if before == after or after >= len(pictures) or stamp[k] not in pictures[after]:
                continue
            gid = _picture_id(pictures[before].get(stamp[k - 1]), truth_xy[k - 1, j])
            if gid is None:
                continue
            done = claimed = None
            for later in range(k, steps):
                if strips[later] != after:
                    break
                published = pictures[after].get(stamp[later])
                if claimed is None and published is not None and any(
                        c.target.name.global_id == gid for c in published.claims):
                    claimed = later
                track = _own_track_on(published, truth_xy[later, j])
                if track is not None and track.global_id == gid and track.detected_ns == stamp[later]:
                    done = later
                    break
            if claimed is not None:
                scores.hand_over_claim_s.append((claimed - k) * step_s)
            if done is None:
                scores.hand_overs_missed += 1
            else:
                scores.hand_over_s.append((done - k) * step_s)


def _take_up(scores: RunScores, pictures, dead: int, killed: int, step_s: float, steps: int) -> None:
    """For each target the dead member alone held, the time to another member's claim and to another member's
    track."""
    last = pictures[dead].get(round((killed - 1) * step_s * NS_PER_S))
    if last is None:
        return
    alone = {t.name.global_id for t in last.picture.targets if t.holders == (last.message.member_id,)}
    for gid in sorted(alone):
        claimed = held = None
        for k in range(killed, steps):
            stamp = round(k * step_s * NS_PER_S)
            for m, by_stamp in enumerate(pictures):
                published = by_stamp.get(stamp) if m != dead else None
                if published is None:
                    continue
                if claimed is None and any(c.target.name.global_id == gid for c in published.claims):
                    claimed = (k - killed) * step_s
                if held is None and any(t.global_id == gid for t in published.message.tracks):
                    held = (k - killed) * step_s
        if claimed is not None:
            scores.take_up_claim_s.append(claimed)
        if held is not None:
            scores.take_up_held_s.append(held)


def fly_central(world: World, base: Scenario, seed: int, config: FederationConfig,
                scene: mt.Scene | None = None) -> RunScores:
    """The same seed (or ``scene``) with one engine flying every UAV (module docstring)."""
    team = _team(base, config)
    roster = [v.id for v in team.vehicles]
    scene = scene or mt.make_scene(world, [v.altitude_m for v in team.vehicles], config.scene,
                                   np.random.default_rng(seed))
    loop = EngineLoop(team, world, np.random.default_rng([seed, 2, 0]))
    tracker = loop.engine.tracker
    step_s = team.time.step_s
    sim = SharingScene(roster, world, scene, tracker.sensors[0], tracker.max_range_m, config.scene.pd,
                       config.scene.clutter, np.random.default_rng([seed, 1]), step_s)
    start, homes = _start(team, config, world)
    airframes = IdealAirframes(roster, start, tracker.max_turn_rate, step_s, team.simulation.airframe.loiter_radius_m,
                               homes)
    loop.declare(roster, 0.0)
    steps = len(scene.truth_xy)
    _fly(loop, sim, airframes, steps, step_s)
    loop.finish(steps * step_s)
    scorer = _Scorer(scene.truth_xy.shape[1])
    for k in range(min(config.scene.warm_up, steps - 1), steps):
        tracks = loop.tracks.get(round(k * step_s * NS_PER_S), [])
        scorer.add([t.target_id for t in tracks], np.array([t.state[:2] for t in tracks]).reshape(-1, 2),
                   np.array([np.array(t.covariance).reshape(4, 4)[:2, :2] for t in tracks]).reshape(-1, 2, 2),
                   None, scene.truth_xy[k])
    changes = scorer.changes()
    return RunScores(float(np.mean(scorer.gospas)), max(changes), float(np.mean(changes)),
                     scorer.nees_inside / max(1, scorer.nees_steps), scorer.swaps(),
                     decision_seconds=_decision_seconds(loop, steps))

