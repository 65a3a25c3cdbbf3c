"""How to run the daemon (:class:`DaemonOptions`): the composition root's frozen configuration of :mod:`gcs.daemon.app`.

The options that change what the engine decides (``accept_unlisted``, ``navigation``,
``max_wait_s``, ``planner``, ``plan_fraction``, ``handback_after_lost_s``, ``federation``) go to its
:class:`~gcs.engine.engine.EngineOptions`; ``gcs replay --process`` takes the same flags.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from gcs.adapters.foxglove_out import FoxgloveOptions
from gcs.adapters.mavlink_commands import DEFAULT_STREAM_RATE_HZ
from gcs.adapters.mavlink_takeover import Takeover
from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.plan_runners import PLAN_PROCESS_NICENESS
from gcs.engine.federation import FederationOptions

__all__ = ["DaemonOptions"]


@dataclass(frozen=True)
class DaemonOptions:
    """How to run the daemon.

    Attributes
    ----------
    zenoh : ZenohSettings
    prefix : str
    mavlink : dict of vehicle id -> connection string, or None for no MAVLink
    signing_key : bytes or None
    seed : int
        Seed of the planner's random generator.
    planner : str or None
        One of :data:`gcs.core.planner_names.PLANNERS`; None takes the scenario's.
    max_wait_s : float
        Wall time a decision step waits for missing vehicles' reports.
    plan_fraction : float
        Share of the planner's deadline it may use (the rest of the step is for
        fusion, visibility maps and I/O).
    record : Path or None
        Record everything received and published to this MCAP file
        (:mod:`gcs.adapters.recording`), finished when the daemon stops.
    plan_runner : str
        Where the planner runs (:mod:`gcs.daemon.plan_runners`): ``process`` (the
        default: a child process, so that planning never takes the interpreter
        from the loop), ``thread``, or ``inline`` (in the loop, each plan made when
        it is handed over; deterministic).
    plan_process_niceness : int
        How much lower the plan process's priority is (0-19; :data:`gcs.daemon.plan_runners.PLAN_PROCESS_NICENESS`).
    http : (host, port) or None
        Serve the live map there (:mod:`gcs.adapters.live_map.outputs`; port 0 picks a free
        one); None: no page.
    foxglove : FoxgloveOptions or None
        Also send the map to a Foxglove WebSocket server and/or MCAP file.
    accept_unlisted : bool
        Accept reports from vehicles outside the scenario's roster (default: rejected as
        ``unknown_vehicle``); their detections are fused with the scenario's sensor model, and they
        are never planned for or commanded; a step waits for the reports of those whose liveliness token is
        declared, as for the roster's.
    stream_rate_hz : float
        The rate asked of every vehicle for GLOBAL_POSITION_INT and ATTITUDE (0: ask nothing;
        :mod:`gcs.adapters.mavlink_commands`).
    takeover : Takeover
        The guard on switching a vehicle to GUIDED (armed, above an altitude) and the mode it is
        given back in (:class:`~gcs.adapters.mavlink_takeover.Takeover`).
    handback_after_lost_s : float
        After this many seconds (stamp time) with no vehicle seeing the target, every vehicle the
        daemon took over is given back; it takes them again when the target is seen again. The
        daemon gives them back when it stops, too.
    navigation : str
        Where a detection's vehicle position comes from (:data:`gcs.engine.navigation.NAVIGATION_MODES`):
        ``skf`` runs feng2019's SKF on each roster vehicle's ``NavReport``s and fuses with its
        estimate and covariance (steps then wait for the nav reports, :mod:`gcs.engine.steps`);
        ``reported`` takes the ``SensorReport``'s own position as exact; ``auto`` (the default) is
        ``skf`` for a scenario with GPS-denied zones, else ``reported``
        (:func:`gcs.engine.navigation.navigator_for`).
    federation : FederationOptions or None
        The daemon is one member of a federation of daemons (``--federation``, ``--member``, ``--area``;
        :mod:`gcs.engine.federation`): it publishes its member tracks and liveliness token under the
        federation's prefix and takes in the other members'.
    """

    zenoh: ZenohSettings
    prefix: str = "gcs"
    mavlink: dict[str, str] | None = None
    signing_key: bytes | None = None
    seed: int = 0
    planner: str | None = None
    max_wait_s: float = 0.5
    plan_fraction: float = 0.6
    record: Path | None = None
    plan_runner: str = "process"
    plan_process_niceness: int = PLAN_PROCESS_NICENESS
    http: tuple[str, int] | None = None
    foxglove: FoxgloveOptions | None = None
    accept_unlisted: bool = False
    navigation: str = "auto"
    stream_rate_hz: float = DEFAULT_STREAM_RATE_HZ
    takeover: Takeover = Takeover()
    handback_after_lost_s: float = 60.0
    federation: FederationOptions | None = None
