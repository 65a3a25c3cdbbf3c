"""Information contributions (wang2012 eq. 13) and the checks of what is fused (eq. 14-15).

:class:`InformationContribution` holds ``(i, I)`` of one or more measurements in the target's
position block; :func:`fusion_inputs` accepts the two call forms of
:meth:`gcs.core.filters.uif.UnscentedInformationFilter.update` and refuses contributions computed
against another prior than the one they are fused into.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.estimate import GaussianEstimate

__all__ = ["InformationContribution", "check_estimate", "fusion_inputs"]


@dataclass(frozen=True)
class InformationContribution:
    """Information contributions of one or more measurements (eq. 13), position block.

    ``H^p`` has zero columns outside the target's position (see
    :func:`pseudo_measurement`), so ``i`` and ``I`` are zero there too; only
    their position parts are stored: ``vector`` (..., 2) and ``matrix``
    (..., 2, 2). A leading axis holds one contribution per vehicle.
    ``prior`` is the estimate they were computed against (set by
    :meth:`~gcs.core.filters.uif.UnscentedInformationFilter.contribution`): the one they may be fused into.
    """

    vector: NDArray[np.float64]
    matrix: NDArray[np.float64]
    prior: GaussianEstimate | None = field(default=None, repr=False, compare=False)

    def total(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Sum over every leading axis: ``(sum i, sum I)``, the terms of eq. (14)."""
        if self.vector.ndim == 1:
            return self.vector, self.matrix
        if self.vector.ndim == 2:
            return self.vector.sum(axis=0), self.matrix.sum(axis=0)
        return self.vector.reshape(-1, 2).sum(axis=0), self.matrix.reshape(-1, 2, 2).sum(axis=0)

    def linearised_about(self, point: GaussianEstimate, prior: GaussianEstimate) -> "InformationContribution":
        """This information, computed about ``point``, declared for fusion into ``prior``.

        An iterated update (Bell and Cathey 1993) linearises eq. (12) about its own
        posterior and fuses the result into the original prior; :meth:`~gcs.core.filters.uif.UnscentedInformationFilter.update`
        refuses that mix unless it is said. ValueError when these contributions were not computed
        against ``point``.
        """
        if self.prior is not point:
            raise ValueError("linearised_about(point, prior): the contributions were computed against another "
                             "estimate than point")
        return InformationContribution(self.vector, self.matrix, prior)

    def full(self, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(i, I)`` in the whole n-dimensional state: shapes (..., n) and (..., n, n)."""
        lead = self.vector.shape[:-1]
        vector = np.zeros(lead + (n,))
        matrix = np.zeros(lead + (n, n))
        vector[..., :2] = self.vector
        matrix[..., :2, :2] = self.matrix
        return vector, matrix


def check_estimate(estimate: object, name: str) -> None:
    if not isinstance(estimate, GaussianEstimate):
        raise TypeError(f"{name} must be a GaussianEstimate, got {type(estimate).__name__}")


def fusion_inputs(prior: GaussianEstimate | InformationContribution | Sequence[InformationContribution],
                  contributions: InformationContribution | Sequence[InformationContribution] | None,
                  ) -> tuple[GaussianEstimate, Sequence[InformationContribution]]:
    """The prior and the contributions of :meth:`~gcs.core.filters.uif.UnscentedInformationFilter.update`, in either call form."""
    given: object = prior  # checked at run time: callers need not be type-checked
    found: object = contributions
    if found is None:  # update(contributions)
        found, given = given, None
    if type(found) is InformationContribution:
        found = [found]
    if type(found) is list and found:  # the usual calls, checked cheaply
        common = found[0].prior if given is None else given
        if isinstance(common, GaussianEstimate) and common.mean.ndim == 1 and all(
                type(c) is InformationContribution and c.prior is common for c in found):
            return common, found
    if isinstance(found, InformationContribution):
        found = [found]
    if not isinstance(found, Sequence) or not all(isinstance(c, InformationContribution) for c in found):
        raise TypeError("contributions must be InformationContribution(s) from contribution(), got "
                        f"{type(found).__name__}")
    if given is None:
        priors = {id(c.prior): c.prior for c in found}
        if not found or None in priors.values():
            raise ValueError("update(contributions) needs contributions made by contribution(), which know their "
                             "prior; otherwise call update(prior, contributions)")
        if len(priors) > 1:
            raise ValueError("the contributions were computed against different priors; fuse each into its own")
        given = found[0].prior
    if not isinstance(given, GaussianEstimate):
        raise TypeError(f"prior must be a GaussianEstimate, got {type(given).__name__}")
    if given.mean.ndim != 1:
        raise ValueError(f"update fuses into one estimate; the prior has mean shape {given.mean.shape}")
    for index, c in enumerate(found):
        if c.prior is not None and c.prior is not given and not _same(c.prior, given):
            raise ValueError(f"contribution {index} was computed against another prior (stamp {c.prior.stamp_ns} "
                             f"ns) than the one given (stamp {given.stamp_ns} ns): predict, then contribute "
                             "against that prediction")
    return given, found


def _same(a: GaussianEstimate, b: GaussianEstimate) -> bool:
    return a.stamp_ns == b.stamp_ns and np.array_equal(a.mean, b.mean) and np.array_equal(a.cov, b.cov)
