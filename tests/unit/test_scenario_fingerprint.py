"""A scenario's fingerprint follows its settings, not how its file is written."""

from __future__ import annotations

import re
from importlib import resources

import msgspec
import numpy as np
import pytest

from gcs.config.fingerprint import FINGERPRINT_DIGITS, scenario_fingerprint
from gcs.scenarios import list_scenarios, load_scenario, parse_scenario
from protocols import VehicleScenario, decode, encode

SHIPPED = (resources.files("gcs.scenarios") / "wang2012_urban.toml").read_text()


def _without_comments(text: str) -> str:
    return "\n".join(line.split("#", 1)[0].rstrip() for line in text.splitlines())


def test_comments_spacing_and_spelled_out_defaults_leave_it_unchanged() -> None:
    reference = scenario_fingerprint(load_scenario("wang2012_urban"))
    assert re.fullmatch(f"[0-9a-f]{{{FINGERPRINT_DIGITS}}}", reference)
    bare = _without_comments(SHIPPED)
    assert bare != SHIPPED and scenario_fingerprint(parse_scenario(bare)) == reference
    spaced = bare.replace(" = ", "=")
    assert scenario_fingerprint(parse_scenario(spaced)) == reference
    # [time] step_s = 1.0 is also the default: leaving it out is the same scenario
    assert "step_s = 1.0" in bare
    assert scenario_fingerprint(parse_scenario(bare.replace("step_s = 1.0", ""))) == reference


@pytest.mark.parametrize(("old", "new"), [
    ("seed = 2012", "seed = 2013"),  # the city
    ("lat_deg = 28.2200", "lat_deg = 28.2201"),  # the frame
    ('name = "wang2012_urban"', 'name = "wang2012_copy"'),  # the same settings under another name
])
def test_any_setting_changes_it(old: str, new: str) -> None:
    assert SHIPPED.count(old) == 1
    assert scenario_fingerprint(parse_scenario(SHIPPED.replace(old, new))) != scenario_fingerprint(
        parse_scenario(SHIPPED))


def test_every_shipped_scenario_has_its_own_and_it_fits_the_wire() -> None:
    prints = {name: scenario_fingerprint(load_scenario(name)) for name in list_scenarios()}
    assert len(set(prints.values())) == len(prints)
    for name, fingerprint in prints.items():
        announcement = VehicleScenario(vehicle_id="uav1", stamp_ns=0, scenario=name, fingerprint=fingerprint)
        assert decode(*encode(announcement)) == announcement


def test_a_scenario_built_in_code_with_numpy_numbers_has_the_fingerprint_of_its_values() -> None:
    scenario = load_scenario("wang2012_urban")
    vehicles = [msgspec.structs.replace(v, speed_mps=np.float64(v.speed_mps)) for v in scenario.vehicles]
    assert scenario_fingerprint(msgspec.structs.replace(scenario, vehicles=vehicles)) == scenario_fingerprint(scenario)
