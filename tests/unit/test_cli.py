"""The command lines list exactly their implemented subcommands and report errors clearly."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import pytest

from gcs import cli as gcs_cli
from sim_vehicles import cli as sim_cli
from tests.e2e.processes import heavy_modules_loaded


def _subcommands(parser) -> set[str]:
    for action in parser._actions:
        if action.__class__.__name__ == "_SubParsersAction":
            return set(action.choices)
    return set()


def test_gcs_help_lists_every_registered_subcommand(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        gcs_cli.main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    names = _subcommands(gcs_cli.build_parser())
    assert "scenario" in names
    for name in names:
        assert name in out


@pytest.mark.parametrize(("argv", "expected"), [
    (["status", "--timeout", "1"], "status"),
    (["--log-level", "DEBUG", "run", "--help"], "run"),
    (["--log-level=ERROR", "replay", "run.mcap"], "replay"),
    (["--help"], None), (["--version"], None), ([], None), (["flyaway"], None), (["-x", "run"], None),
])
def test_only_the_named_subcommand_is_loaded(argv: list[str], expected: str | None) -> None:
    assert gcs_cli.requested_command(argv) == expected
    names = _subcommands(gcs_cli.build_parser(expected) if expected else gcs_cli.COMMAND_LINE.listing_parser())
    assert names == ({expected} if expected else {s.name for s in gcs_cli.SUBCOMMANDS})


@pytest.mark.parametrize("command_line", [gcs_cli.COMMAND_LINE, sim_cli.COMMAND_LINE], ids=["gcs", "sim-vehicles"])
def test_the_listing_shows_each_subcommands_own_help_line(command_line) -> None:
    # the listing (gcs --help) imports no subcommand: its help lines are a copy, held equal to the parsers' own here
    def help_lines(parser) -> dict[str, str]:
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        return {choice.dest: choice.help for choice in action._choices_actions}

    assert help_lines(command_line.listing_parser()) == help_lines(command_line.build_parser())


@pytest.mark.parametrize("argv", [["gcs", "--help"], ["gcs", "--version"], ["sim-vehicles", "--help"],
                                  ["sim-vehicles", "--version"]], ids=" ".join)
def test_help_and_version_load_no_heavy_module(argv: list[str]) -> None:
    assert heavy_modules_loaded("gcs" if argv[0] == "gcs" else "sim_vehicles", argv) == []


def test_gcs_status_loads_neither_scipy_nor_the_daemon() -> None:
    # it is Docker's healthcheck, run every few seconds: it should start in a fraction of a second
    code = ("import sys; from gcs import cli; cli.build_parser(cli.requested_command(['status'])); "
            "print(sorted(m for m in ('scipy', 'gcs.daemon.app', 'gcs.engine.tracker_factory', 'pymavlink') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.strip() == "[]"


def test_an_unknown_subcommand_gets_the_full_list(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        gcs_cli.main(["flyaway"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'flyaway'" in err and "status" in err and "replay" in err


def test_run_takes_the_planners_niceness_0_to_19(capsys: pytest.CaptureFixture[str]) -> None:
    from gcs.daemon.plan_runners import PLAN_PROCESS_NICENESS

    assert gcs_cli.build_parser().parse_args(["run"]).plan_process_niceness == PLAN_PROCESS_NICENESS == 5
    assert gcs_cli.build_parser().parse_args(["run", "--planner-nice", "19"]).plan_process_niceness == 19
    for bad in ("20", "-1", "x"):
        with pytest.raises(SystemExit):
            gcs_cli.build_parser().parse_args(["run", "--planner-nice", bad])
    assert "--planner-nice" in capsys.readouterr().err


def test_sim_vehicles_help_runs(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        sim_cli.main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "sim-vehicles" in out and "run" in out and "payload" in out
    assert set(_subcommands(sim_cli.build_parser())) == {"run", "payload"}


def test_sim_vehicles_run_rejects_bad_arguments_with_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert sim_cli.main(["run", "--rate", "0"]) == 2
    assert sim_cli.main(["run", "--vehicle", "nobody=udpout:127.0.0.1:14999", "--duration", "1"]) == 2
    assert sim_cli.main(["run", "--scenario", "no_such_scenario"]) == 2


def test_scenario_show_prints_the_resolved_scenario(capsys: pytest.CaptureFixture[str]) -> None:
    assert gcs_cli.main(["scenario", "show"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["name"] == "wang2012_urban" and len(shown["vehicles"]) == 3


def test_scenario_list_and_check(capsys: pytest.CaptureFixture[str]) -> None:
    assert gcs_cli.main(["scenario", "list"]) == 0
    assert "wang2012_urban" in capsys.readouterr().out
    assert gcs_cli.main(["scenario", "check", "wang2012_urban"]) == 0
    assert "ok" in capsys.readouterr().out


def test_bad_scenario_exits_2_naming_the_key(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[origin]\nlat_deg = 100.0\nlon_deg = 0.0\n')
    assert gcs_cli.main(["scenario", "check", str(bad)]) == 2
    assert "$.origin.lat_deg" in capsys.readouterr().err


@pytest.mark.parametrize("mode", ["process", "thread", "inline"])
def test_gcs_run_chooses_where_plans_are_made(mode: str) -> None:
    from gcs.daemon.cli import build_daemon

    args = gcs_cli.build_parser().parse_args(["run", "--plan-in", mode, "--mavlink", "none"])
    daemon = build_daemon(args)  # nothing is opened (or started) before Daemon.open
    assert daemon.options.plan_runner == mode and daemon.plan_runner is None


def test_gcs_run_rejects_an_unknown_planner_place(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        gcs_cli.build_parser().parse_args(["run", "--plan-in", "gpu"])
    assert exit_info.value.code == 2 and "--plan-in" in capsys.readouterr().err
