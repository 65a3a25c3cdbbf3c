"""Lost targets: confirmed tracks the tracker deleted, kept for planning as places to look.

A track is deleted after a run of missed scans (:mod:`gcs.core.multitarget.tracks`), but
its target has not gone: it has gone out of every UAV's sight. A planner that only
knows the live tracks never goes back for it. So the last estimate of each deleted
confirmed track is kept, predicted on with the tracker's motion model,

.. math:: x \\leftarrow F x, \\qquad P \\leftarrow F P F^T + Q,

its uncertainty growing as a search region would, together with the time ``u`` it has
gone without a detection (the time it had already missed when it was deleted, then one
step per step). It is forgotten when a confirmed track lies inside its gate,
``d^2 = (p_c - p_l)^T (P_c + P_l)^{-1} (p_c - p_l) <= gamma`` over the position block
(the target was found again), or when ``u`` exceeds ``forget_s``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.motion import LinearMotionModel
from gcs.core.multitarget.tracks import TrackSet

__all__ = ["LostTargets"]


@dataclass(frozen=True)
class LostTargets:
    """L lost targets: ids (L,), ``[x, y, vx, vy]`` means (L, 4), covariances (L, 4, 4), seconds unseen (L,)."""

    ids: NDArray[np.int64]
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    unseen_s: NDArray[np.float64]

    @classmethod
    def none(cls) -> LostTargets:
        return cls(np.zeros(0, dtype=np.int64), np.zeros((0, 4)), np.zeros((0, 4, 4)), np.zeros(0))

    @property
    def size(self) -> int:
        return len(self.ids)

    def add(self, deleted: TrackSet, was_confirmed: NDArray[np.bool_], step_s: float,
            unseen_s: NDArray[np.float64] | None = None) -> LostTargets:
        """These deleted tracks' last estimates, where ``was_confirmed``; each unseen for ``unseen_s`` (one per
        deleted track), or when not given for its missed scans of ``step_s``."""
        keep = np.asarray(was_confirmed, dtype=bool)
        unseen = deleted.misses * float(step_s) if unseen_s is None else np.asarray(unseen_s, dtype=np.float64)
        return LostTargets(np.concatenate([self.ids, deleted.ids[keep]]),
                           np.concatenate([self.mean, deleted.mean[keep]]),
                           np.concatenate([self.cov, deleted.cov[keep]]),
                           np.concatenate([self.unseen_s, unseen[keep]]))

    def advance(self, motion: LinearMotionModel, step_s: float) -> LostTargets:
        """Every lost target predicted one step of ``step_s`` on (module docstring)."""
        f, q = motion.matrices(step_s)
        return LostTargets(self.ids, self.mean @ f.T, f @ self.cov @ f.T + q, self.unseen_s + step_s)

    def forget(self, confirmed: TrackSet, gate: float, forget_s: float) -> LostTargets:
        """Without those found again (a confirmed track inside the gate) or unseen longer than ``forget_s``."""
        keep = self.unseen_s <= forget_s
        if confirmed.size and self.size:
            offset = confirmed.mean[None, :, :2] - self.mean[:, None, :2]  # (L, C, 2)
            covs = confirmed.cov[None, :, :2, :2] + self.cov[:, None, :2, :2]
            d2 = np.einsum("lca,lca->lc", offset, np.linalg.solve(covs, offset[..., None])[..., 0])
            keep &= ~np.any(d2 <= gate, axis=1)
        return LostTargets(self.ids[keep], self.mean[keep], self.cov[keep], self.unseen_s[keep])
