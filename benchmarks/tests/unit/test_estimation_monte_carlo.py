"""Monte Carlo: with 3 UAVs loitering around the target (wang2012's set-up) the DUIF, as the daemon runs it, is
efficient (RMSE at the PCRLB) and consistent (NEES in its chi-square band).

Fixed seed; the data generator has its own measurement formulas (benchmarks.estimation).
"""

from __future__ import annotations

from functools import partial

import pytest

from benchmarks.estimation import (
    SENSOR_STD,
    evaluate,
    generate_dataset,
    nees_band,
    position_bound,
    run_methods,
)
from benchmarks.estimation_methods import duif_stepper
from gcs.core.models.sensor import SensorModel

RUNS, STEPS, SEED = 200, 60, 2012


@pytest.fixture(scope="module")
def duif_metrics() -> dict[str, float]:
    data = generate_dataset(RUNS, STEPS, vehicles=3, seed=SEED)
    result = run_methods(data, {"duif": duif_stepper})["duif"]
    return evaluate(data, result, position_bound(data))


@pytest.mark.slow
def test_rmse_is_within_three_percent_of_the_pcrlb(duif_metrics: dict[str, float]) -> None:
    assert abs(duif_metrics["rmse_over_pcrlb"] - 1.0) <= 0.03, duif_metrics


@pytest.mark.slow
def test_average_nees_is_inside_its_95_percent_band(duif_metrics: dict[str, float]) -> None:
    low, high = nees_band(RUNS)
    assert low <= duif_metrics["nees"] <= high, (duif_metrics["nees"], low, high)


@pytest.mark.slow
def test_a_mistuned_filter_fails_the_same_checks() -> None:
    """The checks have teeth: a filter that believes the sensor is 3x better is caught."""
    data = generate_dataset(40, STEPS, vehicles=3, seed=SEED)
    overconfident = SensorModel.range_bearing(*(s / 3.0 for s in SENSOR_STD))
    result = run_methods(data, {"duif": partial(duif_stepper, sensor=overconfident)})["duif"]
    metrics = evaluate(data, result, position_bound(data))
    low, high = nees_band(40)
    assert metrics["nees"] > high
    assert metrics["rmse_over_pcrlb"] > 1.03
