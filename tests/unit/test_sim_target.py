"""Target truth models: elapsed time, the scripted path and its CSV, the scenario factory."""

from __future__ import annotations

from pathlib import Path

import msgspec
import numpy as np
import pytest

from gcs.config import CityConfig, TargetConfig
from gcs.config.world import build_world
from gcs.core.world import World
from gcs.scenarios import load_scenario
from sim_vehicles.truth.target import (
    ScriptedTarget,
    StreetTarget,
    TargetState,
    WhiteNoiseTarget,
    start_state,
    target_model,
)

BASE = load_scenario("wang2012_urban")
SCENARIO = msgspec.structs.replace(
    BASE,
    city=CityConfig(size_m=(600.0, 600.0), buildings=16, street_width_m=20.0, seed=5),
    target=TargetConfig(start_enu_m=(290.0, 310.0), start_velocity_mps=(1.0, -2.0)),
)
WORLD = build_world(SCENARIO)
PATH = ScriptedTarget(np.array([0.0, 10.0, 20.0]), np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 50.0]]))


def test_every_model_advances_the_elapsed_time() -> None:
    rng = np.random.default_rng(1)
    for motion in ("white_noise_acceleration", "streets"):
        model = target_model(SCENARIO, WORLD, motion)
        state = start_state(model, SCENARIO, rng)
        assert state.elapsed_s == 0.0
        for _ in range(4):
            state = model.step(state, 0.5, rng)
        assert state.elapsed_s == pytest.approx(2.0)
    assert PATH.step(PATH.start(), 2.5, rng).elapsed_s == 2.5


def test_scripted_path_interpolates_and_holds_the_end() -> None:
    state = PATH.start()
    np.testing.assert_array_equal(state.position, [0.0, 0.0])
    np.testing.assert_array_equal(state.velocity, [10.0, 0.0])
    expected = [  # (elapsed, position, velocity): the later segment's slope at a vertex
        (5.0, [50.0, 0.0], [10.0, 0.0]), (10.0, [100.0, 0.0], [0.0, 5.0]), (15.0, [100.0, 25.0], [0.0, 5.0]),
        (20.0, [100.0, 50.0], [0.0, 0.0]), (25.0, [100.0, 50.0], [0.0, 0.0]), (30.0, [100.0, 50.0], [0.0, 0.0]),
    ]
    for elapsed, position, velocity in expected:
        state = PATH.step(state, 5.0, None)
        assert state.elapsed_s == elapsed
        np.testing.assert_allclose(state.position, position)
        np.testing.assert_allclose(state.velocity, velocity)


def test_a_path_starting_later_waits_at_its_first_point() -> None:
    late = ScriptedTarget(np.array([5.0, 10.0]), np.array([[0.0, 0.0], [10.0, 20.0]]))
    state = late.start()
    np.testing.assert_array_equal(state.velocity, [0.0, 0.0])
    np.testing.assert_array_equal(late.step(state, 4.0, None).position, [0.0, 0.0])
    np.testing.assert_allclose(late.step(state, 7.5, None).position, [5.0, 10.0])
    still = ScriptedTarget(np.array([0.0]), np.array([[3.0, 4.0]]))
    np.testing.assert_array_equal(still.step(still.start(), 9.0, None).position, [3.0, 4.0])


@pytest.mark.parametrize(
    ("times", "xy", "message"),
    [([0.0, 1.0, 1.0], [[0, 0], [1, 1], [2, 2]], "strictly increasing"),
     ([0.0, 1.0], [[0, 0]], "N >= 1"), ([], np.zeros((0, 2)), "N >= 1"), ([0.0, np.nan], [[0, 0], [1, 1]], "finite")],
)
def test_bad_scripted_paths_are_rejected(times: list[float], xy: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ScriptedTarget(np.asarray(times), np.asarray(xy, dtype=float))


def test_csv_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "path.csv"
    path.write_text("t_s, x_m, y_m\n0, 0, 0\n\n10, 100.5, -3\n20,100.5,47\n")
    target = ScriptedTarget.from_csv(path)
    np.testing.assert_array_equal(target.times_s, [0.0, 10.0, 20.0])
    np.testing.assert_array_equal(target.xy, [[0.0, 0.0], [100.5, -3.0], [100.5, 47.0]])


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [("time,x,y\n0,0,0\n", ":1:", "header must be t_s,x_m,y_m"),
     ("t_s,x_m,y_m\n0,0,0\n1,abc,0\n", ":3:", "x_m = 'abc' is not a number"),
     ("t_s,x_m,y_m\n0,0,0\n5,1,1\n5,2,2\n", ":4:", "not after the previous"),
     ("t_s,x_m,y_m\n0,0,0\n1,1\n", ":3:", "expected 3 values"),
     ("t_s,x_m,y_m\n0,0,inf\n", ":2:", "not finite"),
     ("t_s,x_m,y_m\n", "", "no points"),
     ("", "", "no points")],
)
def test_bad_csv_files_name_the_file_and_line(tmp_path: Path, text: str, where: str, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as caught:
        ScriptedTarget.from_csv(path)
    assert str(caught.value).startswith(f"{path}{where}")


def test_a_missing_csv_is_a_value_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="cannot read") as caught:
        ScriptedTarget.from_csv(tmp_path / "missing.csv")
    assert str(tmp_path / "missing.csv") in str(caught.value)


def test_white_noise_target_is_blocked_by_buildings_and_the_city_edge() -> None:
    model = target_model(SCENARIO, WORLD)
    assert isinstance(model, WhiteNoiseTarget)
    assert (model.accel_psd_m2_s3, model.max_speed_mps) == (SCENARIO.target.accel_psd_m2_s3, SCENARIO.target.max_speed_mps)
    centres = np.array([f.mean(axis=0) for f in WORLD.buildings.footprints])
    assert model.blocked(centres).all()
    crossings = np.stack(np.meshgrid(WORLD.streets.xs, WORLD.streets.ys), -1).reshape(-1, 2)
    assert not model.blocked(crossings).any()
    np.testing.assert_array_equal(model.blocked(np.array([[-1.0, 300.0], [300.0, 601.0], [601.0, 5.0]])), True)


def test_factory_picks_the_scenarios_motion_or_the_override(tmp_path: Path) -> None:
    streets = target_model(SCENARIO, WORLD, "streets")
    assert isinstance(streets, StreetTarget)
    np.testing.assert_array_equal(streets.xs, WORLD.streets.xs)
    (tmp_path / "route.csv").write_text("t_s,x_m,y_m\n0,10,20\n10,30,20\n")
    scripted_scenario = msgspec.structs.replace(
        SCENARIO, target=msgspec.structs.replace(SCENARIO.target, motion="scripted", path_file="route.csv"))
    scripted = target_model(scripted_scenario, WORLD, base_dir=tmp_path)
    assert isinstance(scripted, ScriptedTarget)
    absolute = msgspec.structs.replace(scripted_scenario, target=msgspec.structs.replace(
        scripted_scenario.target, path_file=str(tmp_path / "route.csv")))
    np.testing.assert_array_equal(target_model(absolute, WORLD, base_dir=Path("/nonexistent")).xy, scripted.xy)
    state = start_state(scripted, scripted_scenario, np.random.default_rng(0))
    np.testing.assert_array_equal(state.vector, [10.0, 20.0, 2.0, 0.0])


def test_factory_errors() -> None:
    with pytest.raises(ValueError, match="path_file"):
        target_model(SCENARIO, WORLD, "scripted")
    with pytest.raises(ValueError, match="unknown target motion"):
        target_model(SCENARIO, WORLD, "teleport")
    with pytest.raises(ValueError, match="streets"):
        target_model(SCENARIO, World.empty(), "streets")


def test_start_states() -> None:
    free = start_state(target_model(SCENARIO, WORLD), SCENARIO, np.random.default_rng(0))
    np.testing.assert_array_equal(free.vector, [290.0, 310.0, 1.0, -2.0])
    street = start_state(target_model(SCENARIO, WORLD, "streets"), SCENARIO, np.random.default_rng(0))
    np.testing.assert_array_equal(street.position, WORLD.streets.nearest_intersection([290.0, 310.0]))
    assert np.linalg.norm(street.velocity) == pytest.approx(10.0)
    assert isinstance(street, TargetState) and street.elapsed_s == 0.0
