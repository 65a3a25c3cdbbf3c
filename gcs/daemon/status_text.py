"""What the daemon's status says, in words: ``gcs status``, the line ``gcs run`` prints as it flies, the meaning
of every counter, and whether the commands' age says the loop keeps up.

Pure text from a :class:`~protocols.messages.DaemonStatus` (no I/O, no clock: the status
carries its own time), importing only the message definitions, so that ``gcs status`` (Docker's
healthcheck) stays quick to start. The counters' meanings (:data:`COUNTERS`) are what
``gcs status --help`` lists and docs/cli.md tabulates.
"""

from __future__ import annotations

from datetime import datetime, timezone

from protocols.messages import DaemonStatus

__all__ = ["COUNTERS", "COUNTER_FAMILIES", "REJECTIONS", "counter_meaning", "counters_help", "format_stamp",
           "command_age_text", "keeps_up", "KEEPS_UP_PERIODS", "format_status", "flight_line"]

NS_PER_S = 1_000_000_000

COUNTERS: dict[str, str] = {
    # what came in over Zenoh
    "accepted.report": "sensor reports (SensorReport) accepted from the scenario's vehicles",
    "accepted.nav": "navigation reports (NavReport: GPS and inertial) accepted",
    "accepted.scenario": "scenario announcements (VehicleScenario) accepted; one naming another scenario is warned of once",
    "accepted.truth": "the simulator's target truth accepted (to score the tracks; never fused)",
    # decision steps and plans
    "decisions": "plans made and applied: their commands were published and the vehicles steered along them",
    "steps_released_by_timeout": "decision steps fused before every vehicle alive had reported (after --max-wait)",
    "steps_fused_only": "decision steps fused but not planned: a newer step was waiting when the planner came free",
    "steps_without_vehicles": "decision steps fused with no vehicle alive (no heartbeat, no liveliness) to plan for",
    "target_lost": "times the vehicles were handed back after --handback-after seconds with no one seeing the target",
    "plans_superseded": "plans dropped unstarted: a newer step's job replaced them while the planner was busy",
    "planner_restarts": "times the planner process died and was started again",
    "nav.applied": "navigation reports applied to a vehicle's position filter (--navigation skf)",
    "nav.applied_early": "navigation reports applied before their step because too many were buffered",
    "nav.waiting_for_fix": "navigation reports held back: the vehicle's filter starts at its first GPS fix",
    "nav.stale": "vehicle positions not used: the filter's last update is too old to extrapolate",
    "nav.unlisted": "navigation reports from a vehicle the navigation filter does not track",
    "errors.decision": "decision steps that failed on a bug (logged with its trace); the daemon went on",
    "errors.planning": "plans that failed on a bug (logged); the vehicles keep the previous plan",
    "errors.ingest": "received items whose handling failed on a bug (logged); the daemon went on",
    "errors.live_map_open": "the live map could not open (its port held?); the vehicles fly without it",
    # a federation of daemons (gcs run --federation)
    "federation.heard": "other members' MemberTracks taken into the federation's picture (newer than the one held)",
    "federation.joined": "other members' liveliness tokens seen declared (a member joined, or was there already)",
    "federation.left": "other members' liveliness tokens withdrawn: their tracks leave the picture",
    # MAVLink, per daemon (summed over the vehicles)
    "mavlink.sent": "MAVLink messages sent, of every kind",
    "mavlink.received": "MAVLink messages received from the scenario's vehicles",
    "mavlink.gcs_heartbeats": "the daemon's own HEARTBEATs, one a second on each link",
    "mavlink.heartbeats": "HEARTBEATs received from the vehicles",
    "mavlink.link_up": "a vehicle heard: its first HEARTBEAT, or the first after it was lost",
    "mavlink.link_lost": "a vehicle silent for 5 s (no HEARTBEAT): it is not commanded until heard again",
    "mavlink.carrots": "SET_POSITION_TARGET_GLOBAL_INT sent: a point ahead on the commanded course, 4 a second",
    "mavlink.heading_commands": "MAV_CMD_GUIDED_CHANGE_HEADING sent to ArduPilot vehicles, when the course changes",
    "mavlink.speed_commands": "MAV_CMD_GUIDED_CHANGE_SPEED sent, when the airspeed changes",
    "mavlink.altitude_commands": "MAV_CMD_GUIDED_CHANGE_ALTITUDE sent, when the altitude changes",
    "mavlink.mode_requests": "mode changes asked (to GUIDED or OFFBOARD to take a vehicle, or the hand-back mode)",
    "mavlink.arm_requests": "arm requests (--takeoff)",
    "mavlink.stream_requests": "telemetry rate requests (SET_MESSAGE_INTERVAL and REQUEST_DATA_STREAM)",
    "mavlink.streams_below_rate": "checks that found telemetry arriving slower than asked (asked again)",
    "mavlink.takeover_held": "switches to GUIDED held back by the takeover guard (disarmed, below "
                             "--takeover-altitude)",
    "mavlink.handbacks": "vehicles given back in the hand-back mode (the daemon stopped, the target was lost)",
    "mavlink.commands_rejected": "COMMAND_ACKs refusing a command (any result but accepted or in progress)",
    "mavlink.no_destination": "messages not sent: a udpin link has nobody to send to until it hears a vehicle",
    "mavlink.send_errors": "sends the socket refused",
    "mavlink.receive_errors": "reads that failed on the socket",
    "mavlink.bad_data": "bytes received that are not MAVLink (or fail their checksum)",
    "mavlink.bad_signature": "messages refused for a missing or wrong signature (signing on)",
    "mavlink.unknown_sysid": "messages from a system id outside the scenario's vehicles (ignored)",
    "mavlink.bad_telemetry": "telemetry outside any plausible range (ignored)",
    "mavlink.positions_without_fix": "positions at lat 0, lon 0, sent before the GPS has a fix (dropped)",
}
"""Every counter of :class:`~protocols.messages.DaemonStatus` by exact name (those of :data:`COUNTER_FAMILIES`
aside): what it counts since the daemon started. Only counters above zero are in a status."""

COUNTER_FAMILIES: dict[str, str] = {
    "accepted.unlisted.": "reports (.report) and navigation reports (.nav) accepted from vehicles outside the "
                          "roster (--accept-unlisted); they are fused, never commanded",
    "rejected.": "messages refused, by reason (the rejected.* rows below); the daemon logs the first few of each",
    "mavlink.ack_": "COMMAND_ACKs received, by result: ack_accepted, ack_denied, ack_unsupported, ack_failed, "
                    "ack_temporarily_rejected, ack_in_progress, ...",
}
"""Counters named by a prefix and a reason or result."""

REJECTIONS: dict[str, str] = {
    "invalid": "a value breaks a type, range or cross-field rule of the message",
    "malformed": "the payload does not parse",
    "oversize": "the payload is over the size limit",
    "encoding": "the Zenoh encoding is missing, malformed or unknown",
    "unexpected_type": "the encoding names another message type than the key",
    "key": "the key expression is not valid under the prefix",
    "unexpected_kind": "a key the daemon does not consume (not a report, nav or truth key)",
    "implausible": "a position or range beyond any plausible bound (over 1000 km)",
    "id_mismatch": "the message's vehicle_id is not its key's",
    "unknown_vehicle": "a vehicle outside the scenario's roster (see --accept-unlisted)",
    "unknown_target": "truth of more targets than the daemon keeps (16)",
    "future": "a stamp more than 60 s after the newest accepted",
    "duplicate": "a stamp already accepted from that source",
    "stale": "a stamp older than the reorder window behind that source's newest",
    "late": "a sensor report whose decision step was already fused",
    "late_nav": "a navigation report older than the step already fused",
    "nav_update": "a navigation report the vehicle's filter could not apply",
    "diverged": "a decision step not fused because its result was absurd (the previous estimate stands)",
    "federation": "a federation member's message that does not decode, or names another member than its key",
}
"""The reasons of the ``rejected.`` counters."""


def counter_meaning(name: str) -> str | None:
    """What the counter ``name`` counts (None for a name nothing here explains)."""
    if name in COUNTERS:
        return COUNTERS[name]
    if name.startswith("rejected."):
        return REJECTIONS.get(name.removeprefix("rejected."))
    for prefix, meaning in COUNTER_FAMILIES.items():
        if name.startswith(prefix) and prefix != "rejected.":
            return meaning
    return None


def counters_help() -> str:
    """Every counter and its meaning, one a line (the epilog of ``gcs status --help``)."""
    rows = [*COUNTERS.items(), *((f"{prefix}*", meaning) for prefix, meaning in COUNTER_FAMILIES.items()),
            *((f"rejected.{reason}", meaning) for reason, meaning in REJECTIONS.items())]
    width = max(len(name) for name, _ in rows)
    return "counters (since the daemon started; only those above zero are shown):\n" + "\n".join(
        f"  {name:<{width}}  {meaning}" for name, meaning in rows)


def format_stamp(stamp_ns: int | None, now_ns: int) -> str:
    """A stamp as UTC time and its age against ``now_ns`` (``2026-12-07T01:14:44Z, 3 s ago``), or ``none``."""
    if stamp_ns is None:
        return "none"
    moment = datetime.fromtimestamp(stamp_ns / NS_PER_S, tz=timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    age_s = (now_ns - stamp_ns) / NS_PER_S
    if age_s >= 0:
        return f"{moment}, {age_s:.0f} s ago"
    return f"{moment}, {-age_s:.0f} s ahead of this clock (simulated vehicles faster than real time?)"


KEEPS_UP_PERIODS = 1.5
"""The median command age, in decision periods, up to which the loop keeps up (:func:`keeps_up`)."""


def keeps_up(median_ms: float, step_s: float) -> bool:
    """Whether the steering commands' age says the loop keeps up with decision steps of ``step_s`` (``T``).

    A command steers along the plan of one decision step. If the loop keeps up, that plan
    is commanded a lag ``L < T`` after the step's stamp (the wait for the reports, fusion
    and planning all fit in a period), and it is flown until the next step's plan replaces
    it, ``T`` later. Commands go out at a steady rate, so their ages spread evenly over
    ``[L, L + T]`` and the median is ``L + T/2 < 1.5 T``. A median above
    :data:`KEEPS_UP_PERIODS` periods means the typical plan came more than a period after
    its step: the loop is behind (a machine too slow, or too loaded, for the rate the
    vehicles fly at). The median, not the 99th percentile, is judged: the first plans of a
    run, made before the loop has measured how fast the vehicles' clock runs, and a rare
    slow plan age a few commands without saying anything of the machine.
    """
    return median_ms <= KEEPS_UP_PERIODS * step_s * 1000.0


def command_age_text(median_ms: float | None, p99_ms: float | None, step_s: float | None,
                     rate: float | None = None) -> str:
    """The commands' age and, given the decision period ``step_s``, whether the loop keeps up (:func:`keeps_up`);
    ``rate`` (a simulation's speed-up) for the advice when it does not."""
    if median_ms is None or p99_ms is None:
        return "command age: no command yet"
    text = f"command age median {median_ms:.0f} ms, p99 {p99_ms:.0f} ms (vehicle time flown less the decision " \
           f"step's stamp)"
    if step_s is None:
        return text
    limit = f"{KEEPS_UP_PERIODS:g} decision periods, {KEEPS_UP_PERIODS * step_s:g} s"
    if keeps_up(median_ms, step_s):
        return f"{text}: the loop keeps up (median under {limit})"
    advice = f"this machine is too slow for --rate {rate:g}; try a lower one" if rate is not None and rate > 1 else \
        "this machine is too slow or too loaded for the live loop"
    return f"{text}: commands flown late (median over {limit}): {advice}"


def format_status(status: DaemonStatus, step_s: float | None = None) -> list[str]:
    """Human-readable lines: the daemon, one line per vehicle, one per track (or ``no tracks``), the counters.
    Stamps are UTC times with their age at the status's own time; ``step_s`` (the scenario's decision
    period, if known) judges the commands' age."""
    now = status.stamp_ns
    lines = [f"scenario {status.scenario}, up {status.uptime_s:.0f} s, status at "
             f"{format_stamp(now, now).split(',')[0]}, last track {format_stamp(status.last_track_stamp_ns, now)}"]
    if status.command_age_ms_median is not None:
        lines.append(command_age_text(status.command_age_ms_median, status.command_age_ms_p99, step_s))
    for vehicle in status.vehicles:
        lines.append(f"  {vehicle.vehicle_id:<10} sysid {vehicle.sysid or '-':>3}  link {vehicle.link:<7} "
                     f"(heartbeat {vehicle.heartbeat or '-'}, liveliness {vehicle.liveliness or '-'})  "
                     f"reports {vehicle.reports:>6}, last {format_stamp(vehicle.last_report_stamp_ns, now)}  "
                     f"autopilot {vehicle.autopilot or '-'}  control {vehicle.control or '-'}")
    for track in status.tracks:
        speed = "-" if track.speed_mps is None else f"{track.speed_mps:.1f} m/s"
        lines.append(f"  track {track.target_id:<10} at ({track.x_m:.1f}, {track.y_m:.1f}) m  "
                     f"1-sigma {track.position_std_m:.1f} m  speed {speed}  {format_stamp(track.stamp_ns, now)}  "
                     f"vehicles {', '.join(track.contributing_vehicles) or '-'}")
    if not status.tracks:
        lines.append("  no tracks")
    for name, value in sorted(status.counters.items()):
        lines.append(f"  {name:<40} {value:>10}")
    return lines


def flight_line(status: DaemonStatus, flown_s: float, steps: int, seen: int, step_s: float) -> str:
    """The one line ``gcs run`` prints every 30 s of flight: ``flown_s`` seconds of the vehicles' time since the
    first step, ``steps`` decision steps fused, ``seen`` of them with the target in some vehicle's sight."""
    linked = sum(vehicle.link == "ok" for vehicle in status.vehicles)
    steered = sum(vehicle.control == "daemon" for vehicle in status.vehicles)
    counters = status.counters
    rejected = sum(value for name, value in counters.items() if name.startswith("rejected."))
    tracks = ", ".join(f"{t.target_id} 1-sigma {t.position_std_m:.0f} m" for t in status.tracks[:3]) or "none"
    if len(status.tracks) > 3:
        tracks += f" and {len(status.tracks) - 3} more"
    median, p99 = status.command_age_ms_median, status.command_age_ms_p99
    age = "-" if median is None or p99 is None else (
        f"{median / 1000:.1f}/{p99 / 1000:.1f} s " + ("ok" if keeps_up(median, step_s) else "LATE"))
    control = f", {steered} steered" if any(vehicle.control is not None for vehicle in status.vehicles) else ""
    return (f"flown {flown_s:.0f} s: vehicles {linked}/{len(status.vehicles)} linked{control}; steps {steps}, "
            f"target seen in {seen}/{steps}; plans {counters.get('decisions', 0)}; tracks: {tracks}; "
            f"command age median/p99 {age}; rejected {rejected}")
