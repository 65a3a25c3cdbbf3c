"""``gcs-bench estimation``'s two filters on its generated data: the DUIF agrees with FilterPy's covariance-form UKF."""

from __future__ import annotations

import numpy as np

from benchmarks.estimation import generate_dataset, run_methods
from benchmarks.estimation_methods import duif_eq13_stepper, filterpy_stepper


def test_duif_agrees_with_a_covariance_form_ukf_on_the_same_data() -> None:
    """Oracle: FilterPy's stacked UKF (covariance form) on the same generated data."""
    data = generate_dataset(runs=3, steps=80, vehicles=3, seed=11)
    results = run_methods(data, {"duif": duif_eq13_stepper, "ukf": filterpy_stepper})  # eq. (12)-(13): the UKF's terms
    for run in range(3):
        duif_means, duif_covs = results["duif"].means[run], results["duif"].covs[run]
        ukf_means, ukf_covs = results["ukf"].means[run], results["ukf"].covs[run]
        sigma = np.sqrt(np.einsum("kii->ki", ukf_covs))
        # After the first steps (prior much wider than the measurements) they agree to a
        # small fraction of a standard deviation; they differ only by the UKF's extra
        # second-order term in P_zz, which the information form drops (eq. 12).
        gap = np.abs(duif_means - ukf_means) / sigma
        assert gap.max() < 0.3
        assert gap[10:].max() < 0.05
        ratio = np.einsum("kii->ki", duif_covs[5:]) / np.einsum("kii->ki", ukf_covs[5:])
        assert np.all(np.abs(ratio - 1.0) < 0.01)

