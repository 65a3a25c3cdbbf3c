"""A track in brief for the daemon's status: :func:`summarise_track`.

Pure: a :class:`~protocols.messages.TrackEstimate` in, a :class:`~protocols.messages.TrackSummary`
out, for ``DaemonStatus.tracks`` and ``gcs status``.
"""

from __future__ import annotations

import math

from protocols.messages import TrackEstimate, TrackSummary

__all__ = ["summarise_track"]

DECIMALS = 2
"""Positions, 1-sigma and speed are rounded to this many decimals (centimetres, cm/s)."""


def worst_axis_std(p_xx: float, p_xy: float, p_yy: float) -> float:
    """1-sigma along the worst axis of the 2x2 covariance ``[[p_xx, p_xy], [p_xy, p_yy]]``, metres.

    The square root of its largest eigenvalue,
    ``lambda_max = (p_xx + p_yy) / 2 + sqrt(((p_xx - p_yy) / 2)^2 + p_xy^2)``,
    clipped at 0 (a block that is not positive semi-definite has no real spread below it).
    """
    lambda_max = 0.5 * (p_xx + p_yy) + math.hypot(0.5 * (p_xx - p_yy), p_xy)
    return math.sqrt(max(lambda_max, 0.0))


def summarise_track(track: TrackEstimate) -> TrackSummary:
    """The status's summary of one track.

    The state's first two entries are the ENU position (x, y), metres, and, when there are at least
    four, the next two the velocity (vx, vy), m/s, as in every model the daemon publishes
    (``cv2d``, ``ca2d``). ``covariance`` is row-major ``n x n``; its (x, y) block is entries
    ``[0, 1, n, n + 1]``, the off-diagonal taken as the mean of the two (the wire allows them to
    differ by rounding).

    Raises
    ------
    ValueError
        If the state has fewer than two entries (no horizontal position).
    """
    n = len(track.state)
    if n < 2:
        raise ValueError(f"track {track.target_id!r} has {n} state entries: no horizontal position")
    cov = track.covariance
    std = worst_axis_std(cov[0], 0.5 * (cov[1] + cov[n]), cov[n + 1])
    speed = round(math.hypot(track.state[2], track.state[3]), DECIMALS) if n >= 4 else None
    return TrackSummary(target_id=track.target_id, stamp_ns=track.stamp_ns,
                        x_m=round(track.state[0], DECIMALS), y_m=round(track.state[1], DECIMALS),
                        position_std_m=round(std, DECIMALS), speed_mps=speed,
                        contributing_vehicles=track.contributing_vehicles)
