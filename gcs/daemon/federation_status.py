"""``gcs status --federation PREFIX``: a federation of daemons as its members publish it.

The daemon's own status (:class:`~protocols.messages.DaemonStatus`) says nothing of a federation
but its counters (``federation.heard``, ``federation.left``). What the federation holds is in
the members' own messages: every member answers a query of ``PREFIX/federation/*/tracks``
with its latest :class:`~protocols.federation.MemberTracks` (:mod:`gcs.adapters.zenoh_io`). This
module asks for them and puts them in words: one line per member (area, vehicles, spare vehicles,
tracks, stamp) and one per global track (its global id, the members holding it, where the
newest holder has it), and the lost targets the members search for.

Like :mod:`gcs.daemon.status_cli` it imports only Zenoh and the message definitions.
"""

from __future__ import annotations

import logging

from gcs.adapters.zenoh_session import open_session, query
from gcs.daemon.status_text import format_stamp
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.federation import FederatedTrack, MemberTracks
from protocols.keys import member_tracks_selector

__all__ = ["query_federation", "format_federation"]

log = logging.getLogger(__name__)


def query_federation(settings, prefix: str, timeout_s: float) -> list[MemberTracks]:
    """Each member's latest tracks, by member id; empty when no member answered within ``timeout_s``. A reply
    that does not decode is logged and left out."""
    members: dict[str, MemberTracks] = {}
    with open_session(settings) as session:
        for sample in query(session, member_tracks_selector(prefix), timeout_s):
            try:
                message = decode(sample.payload.to_bytes(), str(sample.encoding), MemberTracks)
            except ProtocolError as error:
                log.warning("reply on %s left out: %s", sample.key_expr, error)
                continue
            members[message.member_id] = message
    return [members[member_id] for member_id in sorted(members)]


def _global_tracks(members: list[MemberTracks]) -> dict[str, list[tuple[str, FederatedTrack]]]:
    """Every member's tracks by global id: (member, track), newest stamp first."""
    by_id: dict[str, list[tuple[str, FederatedTrack]]] = {}
    for message in members:
        for track in message.tracks:
            by_id.setdefault(track.global_id, []).append((message.member_id, track))
    return {gid: sorted(rows, key=lambda row: (-row[1].stamp_ns, row[0])) for gid, rows in sorted(by_id.items())}


def format_federation(prefix: str, members: list[MemberTracks], now_ns: int) -> list[str]:
    """Human-readable lines: the federation, one line per member, one per global track, the searches.
    Stamps are UTC times with their age at ``now_ns``."""
    lines = [f"federation {prefix}: {len(members)} member{'s' if len(members) != 1 else ''} "
             f"({', '.join(m.member_id for m in members)})"]
    for m in members:
        x_min, y_min, x_max, y_max = m.area_enu_m
        lines.append(f"  member {m.member_id:<10} area ({x_min:.0f}, {y_min:.0f})-({x_max:.0f}, {y_max:.0f}) m  "
                     f"vehicles {m.vehicles}, spare {m.spare_vehicles}  tracks {len(m.tracks)}  "
                     f"seq {m.seq}  stamp {format_stamp(m.stamp_ns, now_ns)}")
    tracks = _global_tracks(members)
    for gid, rows in tracks.items():
        newest_member, newest = rows[0]
        lines.append(f"  global track {gid:<16} held by {', '.join(member for member, _ in rows)}  "
                     f"at ({newest.state[0]:.1f}, {newest.state[1]:.1f}) m ({newest_member}'s, "
                     f"{format_stamp(newest.stamp_ns, now_ns)})")
    if not tracks:
        lines.append("  no global tracks")
    for m in members:
        for gid in m.searching:
            lines.append(f"  lost target {gid:<16} searched for by {m.member_id}")
    return lines
