"""zuo2021's closed loops stepped alternately keep their own state: each planner flies what it flies alone."""

from __future__ import annotations

import numpy as np

from benchmarks.aoa import AoaScenario
from benchmarks.aoa_loop import run_alternated, run_loop


def test_alternated_planners_fly_as_alone() -> None:
    setup = AoaScenario(steps=6)
    together = run_alternated(setup, ["gcrlb_lm", "crlb_lm", "straight_line"], seed=9)
    for name, record in together.items():
        alone = run_loop(setup, name, 9)
        np.testing.assert_array_equal(record.vehicle_xy, alone.vehicle_xy, err_msg=name)
        np.testing.assert_array_equal(record.squared_error, alone.squared_error, err_msg=name)
    assert not np.array_equal(together["gcrlb_lm"].vehicle_xy, together["straight_line"].vehicle_xy)
