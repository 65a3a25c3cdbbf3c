"""Scenario files: the shipped default matches the paper; bad files name the bad key."""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest

from gcs.config import Scenario, ScenarioError, validate_scenario
from gcs.config.simulation import AirframeConfig, SimulationConfig
from gcs.scenarios import DEFAULT_SCENARIO, list_scenarios, load_scenario, parse_scenario

MINIMAL = b"""
name = "tiny"
[origin]
lat_deg = 1.0
lon_deg = 2.0
[[vehicles]]
id = "a"
sysid = 1
altitude_m = 100.0
speed_mps = 20.0
max_turn_rate_rad_s = 0.2
start_enu_m = [10.0, 10.0]
"""


def test_default_scenario_is_wang2012_section5() -> None:
    s = load_scenario(DEFAULT_SCENARIO)
    assert DEFAULT_SCENARIO == "wang2012_urban" and DEFAULT_SCENARIO in list_scenarios()
    assert [v.altitude_m for v in s.vehicles] == [200.0, 210.0, 220.0]
    assert {v.speed_mps for v in s.vehicles} == {25.0}
    assert {v.max_turn_rate_rad_s for v in s.vehicles} == {0.2}
    assert (s.sensor.range_std_m, s.sensor.azimuth_std_rad, s.sensor.elevation_std_rad) == (10.0, 0.05, 0.05)
    assert s.city.size_m == (3000.0, 3000.0) and s.city.buildings == 400
    assert (s.time.step_s, s.time.duration_s) == (1.0, 300.0)
    assert (s.planner.horizon_steps, s.planner.population, s.planner.generations) == (5, 50, 200)


def test_every_shipped_scenario_loads() -> None:
    for name in list_scenarios():
        assert isinstance(load_scenario(name), Scenario)


def test_config_is_frozen() -> None:
    s = load_scenario(DEFAULT_SCENARIO)
    with pytest.raises(AttributeError):
        s.name = "other"  # type: ignore[misc]


def test_minimal_file_gets_defaults() -> None:
    s = parse_scenario(MINIMAL)
    assert s.time.step_s == 1.0 and s.sensor_for(s.vehicles[0]) is s.sensor


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        ((b"speed_mps = 20.0", b"speed_mps = -20.0"), "$.vehicles[0].speed_mps"),
        ((b"speed_mps = 20.0", b'speed_mps = "fast"'), "$.vehicles[0].speed_mps"),
        ((b"sysid = 1", b"sysid = 300"), "$.vehicles[0].sysid"),
        ((b'id = "a"', b'id = "a b"'), "$.vehicles[0].id"),
        ((b"lat_deg = 1.0", b"lat_deg = 95.0"), "$.origin.lat_deg"),
        ((b"lat_deg = 1.0", b"lat_deg = 1.0\nbogus = 3"), "bogus"),
        ((b"start_enu_m = [10.0, 10.0]", b"start_enu_m = [-10.0, 10.0]"), "$.vehicles[0].start_enu_m"),
        ((b"sysid = 1\n", b""), "sysid"),
    ],
)
def test_bad_value_names_the_key(edit: tuple[bytes, bytes], key: str) -> None:
    text = MINIMAL.replace(*edit)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, source="bad.toml")
    assert "bad.toml" in str(info.value) and key in str(info.value)


def test_duplicate_ids_are_named() -> None:
    vehicle = MINIMAL.split(b"[[vehicles]]")[1]
    with pytest.raises(ScenarioError, match=r"\$\.vehicles\[1\]\.id: duplicate vehicle id 'a'.*\$\.vehicles\[1\]\.sysid"):
        parse_scenario(MINIMAL + b"[[vehicles]]" + vehicle)


def test_range_sensor_needs_range_noise() -> None:
    with pytest.raises(ScenarioError, match=r"\$\.sensor\.range_std_m"):
        parse_scenario(MINIMAL + b'[sensor]\nkind = "range_bearing"\nrange_std_m = 0.0\n')


def test_not_toml_and_unknown_name_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="not valid TOML"):
        parse_scenario(b"name = ", source="x.toml")
    with pytest.raises(ScenarioError, match="unknown scenario 'nope'.*wang2012_urban"):
        load_scenario("nope")
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "missing.toml")


def test_load_from_path_round_trips(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_bytes(MINIMAL)
    s = load_scenario(path)
    assert s.name == "tiny"
    assert msgspec.json.decode(msgspec.json.encode(s), type=Scenario) == s


def test_simulation_section_defaults_and_airspeed_band_checked():
    scenario = load_scenario("wang2012_urban")
    assert scenario.simulation.report_rate_hz == 1.0 and scenario.gps_denied == []
    slow = msgspec.structs.replace(scenario, simulation=SimulationConfig(airframe=AirframeConfig(min_airspeed_mps=30.0)))
    with pytest.raises(ScenarioError, match=r"\$\.vehicles\[0\]\.speed_mps"):
        validate_scenario(slow)


def test_multitarget_table_defaults_and_its_rules_name_the_key() -> None:
    assert parse_scenario(MINIMAL).multitarget is None  # without the table: the single-target estimator
    tracked = parse_scenario(MINIMAL + b"[multitarget]\n").multitarget
    assert (tracked.association, tracked.confirm_m, tracked.confirm_n, tracked.max_misses) == ("jpda", 3, 4, 5)
    assert load_scenario("multitarget_urban").multitarget is not None
    with pytest.raises(ScenarioError, match=r"\$\.multitarget\.confirm_m: 4 is more than confirm_n 3"):
        parse_scenario(MINIMAL + b"[multitarget]\nconfirm_m = 4\nconfirm_n = 3\n")
    with pytest.raises(ScenarioError, match=r"\$\.multitarget: needs every vehicle's sensor of kind 'range_bearing'"):
        parse_scenario(MINIMAL + b'[sensor]\nkind = "bearing_only"\n[multitarget]\n')
    with pytest.raises(ScenarioError, match=r"\$\.multitarget: needs every sensor's detection_probability above 0"):
        parse_scenario(MINIMAL + b"[sensor]\ndetection_probability = 0.0\n[multitarget]\n")
    with pytest.raises(ScenarioError, match=r"\$\.planner\.kind: 'orbit' cannot share the UAVs"):
        parse_scenario(MINIMAL + b'[planner]\nkind = "orbit"\n[multitarget]\n')
    with pytest.raises(ScenarioError, match=r"association"):
        parse_scenario(MINIMAL + b'[multitarget]\nassociation = "mht"\n')
