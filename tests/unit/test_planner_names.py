"""One scheme of planner names: a scenario's ``[planner] kind`` and ``gcs run --planner`` take the same names,
each built into the class :data:`gcs.core.planners.PLANNER_CLASSES` gives it."""

from __future__ import annotations

import argparse

import msgspec
import pytest

from gcs.config import ScenarioError
from gcs.core.planner_names import DEFAULT_PLANNER, MULTITARGET_PLANNERS, PLANNERS
from gcs.core.planners import PLANNER_CLASSES, OneStepHeadingPlanner, SightPlanner
from gcs.daemon.cli import add_daemon_arguments
from gcs.engine.tracker_factory import scenario_planner, tracker_config
from gcs.scenarios import list_scenarios, load_scenario, parse_scenario
from tests.unit.test_scenarios import MINIMAL


def test_every_name_has_one_planner_class_and_the_default_is_the_sight_planner() -> None:
    assert tuple(PLANNER_CLASSES) == PLANNERS and len(set(PLANNERS)) == len(PLANNERS)
    assert DEFAULT_PLANNER == "sight" and PLANNER_CLASSES[DEFAULT_PLANNER] is SightPlanner
    assert set(MULTITARGET_PLANNERS) <= set(PLANNERS)


@pytest.mark.parametrize("name", PLANNERS)
def test_a_scenario_naming_a_planner_gets_that_planner_and_the_command_line_accepts_the_name(name: str) -> None:
    scenario = load_scenario("zuo2021_aoa" if name in ("gcrlb_lm", "crlb_lm", "straight") else "wang2012_urban")
    scenario = msgspec.structs.replace(scenario, planner=msgspec.structs.replace(scenario.planner, kind=name))
    assert scenario_planner(scenario) == name
    planner = tracker_config(scenario, None, scenario_planner(scenario)).planner
    built = planner.solver if isinstance(planner, OneStepHeadingPlanner) else planner
    assert isinstance(built, PLANNER_CLASSES[name])
    parser = argparse.ArgumentParser()
    add_daemon_arguments(parser)
    assert parser.parse_args(["--planner", name]).planner == name


def test_the_shipped_scenarios_name_their_planners_as_the_command_line_does() -> None:
    assert {load_scenario(name).planner.kind for name in list_scenarios()} <= set(PLANNERS)


@pytest.mark.parametrize("kind", ["ga_rhc", "k0", "SIGHT"])
def test_an_unknown_planner_is_an_error_that_lists_the_names(kind: str) -> None:
    with pytest.raises(ScenarioError) as error:
        parse_scenario(MINIMAL + f'[planner]\nkind = "{kind}"\n'.encode(), source="tiny.toml")
    assert str(error.value) == (f"tiny.toml: $.planner.kind: unknown planner {kind!r}; expected one of: "
                                + ", ".join(PLANNERS))
