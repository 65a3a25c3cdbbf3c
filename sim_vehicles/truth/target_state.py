"""The ground target's true state, shared by every truth model of :mod:`sim_vehicles.truth.target`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["TargetState"]


@dataclass(frozen=True)
class TargetState:
    """Ground-truth target: ENU position (2,), velocity (2,) and the time since the start, seconds."""

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    elapsed_s: float = 0.0

    @property
    def vector(self) -> NDArray[np.float64]:
        """``[x, y, vx, vy]``."""
        return np.concatenate([self.position, self.velocity])
