"""Manoeuvre libraries: a fixed-wing's reachable paths over a horizon, as turn-rate plans.

A primitive holds one turn rate per segment: the horizon's ``T`` steps are cut
into ``segments`` nearly equal parts and each part flies one of ``levels``
fractions of the vehicle's maximum turn rate ``eta``. With 5 levels and 3
segments that is 125 plans per vehicle, from a hard turn held throughout to
S-turns, which cover the set of places a fixed-wing can reach in ``T`` steps
(eq. 1 with ``|u| <= eta``) well enough to seed a search, and to fall back on.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray

__all__ = ["LEVELS", "primitives"]

LEVELS = (-1.0, -0.5, 0.0, 0.5, 1.0)
"""Default fractions of the maximum turn rate a segment may hold."""


def primitives(eta: float, steps: int, levels: tuple[float, ...] = LEVELS, segments: int = 3) -> NDArray[np.float64]:
    """Every plan (C, steps) of ``segments`` held turn rates ``level * eta``; C = len(levels) ** segments.

    Segment boundaries: ``round(k steps / segments)``, so earlier segments are
    never longer than later ones. Fewer steps than segments: one segment per step.
    """
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    segments = max(1, min(segments, steps))
    edges = [round(k * steps / segments) for k in range(segments + 1)]
    lengths = np.diff(edges)
    combos = np.array(list(itertools.product(levels, repeat=segments)), dtype=np.float64)  # (C, segments)
    return np.repeat(combos, lengths, axis=1) * eta
