"""What goes into the engine (:class:`~gcs.engine.engine.Engine`) and what comes out of it.

Inputs are frozen records, each carrying the time at which its shell received it
(``now_s``, seconds of the shell's loop clock: ``time.monotonic`` live, the recorded
receive time in ``gcs replay``). The engine never reads a clock; everything it
decides by time (a step's reorder window, whether a vehicle is alive, when to hand a
plan over) is decided by these stamps, so that a recording fed back with its receive
times gives the decisions the live run made.

Actions are what the engine asks its shell to do: publish, plan, give vehicles back,
show a message on the live map. The daemon (:mod:`gcs.daemon.app`) carries them out on Zenoh
and MAVLink; ``gcs replay --process`` (:mod:`gcs.recordings.replay`) collects them; the benchmarks'
closed loops (``gcs-bench``) fly them.
"""

from __future__ import annotations

from dataclasses import dataclass

from gcs.engine.federation import PublishMemberTracks
from gcs.engine.plan_jobs import PlanJob, PlanOutcome
from protocols.messages import NavReport, PlanCommand, SensorReport, TargetTruth, TrackEstimate, VehicleScenario

__all__ = ["Arrived", "Heartbeat", "Tick", "PlanDone", "PlannerFree", "Observed", "PublishTrack", "PublishPlan",
           "SubmitPlan", "LetGo", "PublishMemberTracks", "Action", "Input"]


# ------------------------------------------------------------------ inputs

@dataclass(frozen=True)
class Arrived:
    """A Zenoh sample (``kind`` ``sample``) or a liveliness change (``alive`` or ``gone``) as received:
    the key, the exact payload and Zenoh encoding, ``received_ns`` (the recording's log time) and the
    loop time ``now_s`` at which the shell handed it over."""

    kind: str
    key: str
    payload: bytes
    encoding: str
    received_ns: int
    now_s: float


@dataclass(frozen=True)
class Heartbeat:
    """A MAVLink HEARTBEAT from a roster vehicle, heard at loop time ``heard_s`` (a vehicle is alive
    while its token is declared or its heartbeat is recent: :mod:`gcs.engine.registry`)."""

    vehicle_id: str
    heard_s: float


@dataclass(frozen=True)
class Tick:
    """The clock moved on to ``now_s``: release the decision steps that are ready.

    ``timeouts``: steps may also be released by their wait running out (a shell still holding
    received items passes False: a step's missing report may be among them). ``max_steps``: fuse at
    most this many of the released steps now (the rest wait for the next tick; the daemon applies
    finished plans in between). ``wall_ns`` (``time.time_ns``) and ``monotonic_s`` stamp the step
    records and plan jobs for the latency figures; they decide nothing.
    """

    now_s: float
    timeouts: bool = True
    max_steps: int | None = None
    wall_ns: int = 0
    monotonic_s: float = 0.0


@dataclass(frozen=True)
class PlanDone:
    """A plan the planner finished."""

    outcome: PlanOutcome


@dataclass(frozen=True)
class PlannerFree:
    """The planner is not planning at loop time ``now_s``: the newest fused step may be handed to it."""

    now_s: float


Input = Arrived | Heartbeat | Tick | PlanDone | PlannerFree


# ----------------------------------------------------------------- actions

@dataclass(frozen=True)
class Observed:
    """An accepted input message (a vehicle's scenario announcement too), for the live map."""

    message: SensorReport | NavReport | TargetTruth | VehicleScenario


@dataclass(frozen=True)
class PublishTrack:
    """A fused step's track, to publish."""

    track: TrackEstimate


@dataclass(frozen=True)
class RetireTrack:
    """A track the multi-target tracker deleted: no longer published, nor answered to queries."""

    target_id: str


@dataclass(frozen=True)
class PublishPlan:
    """One vehicle's plan, to publish."""

    command: PlanCommand


@dataclass(frozen=True)
class SubmitPlan:
    """A job for the planner (it replaces one still waiting: the newest step wins)."""

    job: PlanJob


@dataclass(frozen=True)
class LetGo:
    """Stop steering these vehicles and give back those taken over (``why`` goes to the log)."""

    vehicle_ids: tuple[str, ...]
    why: str


Action = Observed | PublishTrack | RetireTrack | PublishPlan | SubmitPlan | LetGo | PublishMemberTracks
