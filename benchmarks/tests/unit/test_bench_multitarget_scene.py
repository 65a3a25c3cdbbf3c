"""The multitarget bench's scene: the side-by-side pair, targets on the streets, the UAVs' orbits."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.multitarget import ORBITS, BenchConfig, make_scene


@pytest.fixture(scope="module")
def world():
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    return build_world(load_scenario("wang2012_urban"))


@pytest.mark.parametrize("seed", [0, 1, 7])
def test_pair_rides_at_the_offset_then_separates_and_all_stay_on_streets(world, seed: int) -> None:
    config = BenchConfig(targets=5, steps=90, pair_offset_m=7.0)
    scene = make_scene(world, [200.0, 210.0, 220.0], config, np.random.default_rng(seed))
    assert scene.truth_xy.shape == (90, 5, 2) and scene.vehicle_xyz.shape == (90, 3, 3)
    gap = np.linalg.norm(scene.truth_xy[:, 0] - scene.truth_xy[:, 1], axis=1)
    joint = config.joint_steps
    np.testing.assert_allclose(gap[:joint], 7.0, atol=1e-9)
    assert gap[-1] > 50.0  # the partner drives at 0.6 of the lead's speed afterwards
    assert world.streets.on_street(scene.truth_xy).all()
    step = np.linalg.norm(np.diff(scene.truth_xy[:, 2:], axis=0), axis=-1)
    assert (step <= 10.0 + 1e-9).all()  # 10 m/s street speed, 1 s steps


def test_orbits_are_fixed_circles_at_the_altitudes(world) -> None:
    scene = make_scene(world, [200.0, 210.0, 220.0], BenchConfig(steps=20), np.random.default_rng(3))
    for v, (cx, cy, radius) in enumerate(ORBITS):
        r = np.hypot(scene.vehicle_xyz[:, v, 0] - cx, scene.vehicle_xyz[:, v, 1] - cy)
        np.testing.assert_allclose(r, radius)
        np.testing.assert_allclose(scene.vehicle_xyz[:, v, 2], [200.0, 210.0, 220.0][v])
        speed = np.linalg.norm(np.diff(scene.vehicle_xyz[:, v, :2], axis=0), axis=1)
        assert np.all(np.abs(speed - 25.0) < 0.1)  # chords of a 25 m/s orbit


def test_same_seed_same_scene(world) -> None:
    a = make_scene(world, [200.0, 210.0, 220.0], BenchConfig(steps=10), np.random.default_rng(5))
    b = make_scene(world, [200.0, 210.0, 220.0], BenchConfig(steps=10), np.random.default_rng(5))
    np.testing.assert_array_equal(a.truth_xy, b.truth_xy)


def test_without_stone_soup_ours_run_and_the_report_says_so(monkeypatch) -> None:
    import sys

    from benchmarks import multitarget_report

    monkeypatch.setitem(sys.modules, "benchmarks.stonesoup_peer", None)  # importing it raises ImportError
    notes = []
    report = multitarget_report.run_benchmark(BenchConfig(targets=2, steps=12, warm_up=2), runs=1, seed=0, peers=True,
                                              progress=notes.append)
    assert set(report["methods"]) == {"gnn", "jpda", "gnn_roads", "jpda_roads"}
    assert report["note"].startswith("Stone Soup peers not run") and report["note"] in notes
    assert report["note"] in multitarget_report.format_report(report).splitlines()
