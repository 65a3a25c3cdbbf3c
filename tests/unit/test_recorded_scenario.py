"""A recording keeps its scenario, and ``gcs replay`` uses it unless ``--scenario`` says otherwise (with a warning)."""

from __future__ import annotations

import logging

import pytest

from gcs.adapters.recording import Recorder, read_recording
from sim_vehicles.recording import record_scene
from gcs.cli import main
from gcs.cli_errors import UsageError
from gcs.config.fingerprint import scenario_fingerprint
from gcs.config.world import build_world
from gcs.recordings.recorded_scenario import recording_contents, replay_scenario
from gcs.recordings.replay import summarise
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import report_key, scenario_key, status_key
from protocols.messages import DaemonStatus, SensorReport, VehicleScenario

S = 1_000_000_000
URBAN = load_scenario("wang2012_urban")
DENSE = load_scenario("downtown_dense")


def _announcement(scenario: str, fingerprint: str, vehicle: str = "uav1") -> tuple[str, bytes, str]:
    message = VehicleScenario(vehicle_id=vehicle, stamp_ns=S, scenario=scenario, fingerprint=fingerprint)
    return (scenario_key(vehicle), *encode(message))


def _recording(path, *announced: tuple[str, str], metadata=None, reports: int = 3):
    """A recording of a few reports, each vehicle's announcement first (as the vehicles publish them)."""
    with Recorder(path, scenario=metadata) as recorder:
        for k, (name, fingerprint) in enumerate(announced):
            recorder.write(*_announcement(name, fingerprint, f"uav{k + 1}"), S)
        for seq in range(reports):
            report = SensorReport(vehicle_id="uav1", seq=seq, stamp_ns=(seq + 1) * S,
                                  vehicle_position_enu_m=(1.0, 2.0, 200.0))
            recorder.write(report_key("uav1"), *encode(report), (seq + 1) * S)
    return path


def test_the_daemons_metadata_comes_first_and_announcements_otherwise(tmp_path) -> None:
    urban = (URBAN.name, scenario_fingerprint(URBAN))
    dense = (DENSE.name, scenario_fingerprint(DENSE))
    # gcs run --record: its own scenario, whatever its vehicles announced
    assert recording_contents(_recording(tmp_path / "a.mcap", dense, metadata=URBAN)).scenario == urban
    # gcs record: the first announcement
    contents = recording_contents(_recording(tmp_path / "b.mcap", dense, urban))
    assert contents.scenario == dense and contents.has_report
    nothing = recording_contents(_recording(tmp_path / "c.mcap", reports=0))
    assert nothing.scenario is None and not nothing.has_report
    assert summarise(tmp_path / "b.mcap")["scenario"] == {"name": dense[0], "fingerprint": dense[1]}
    assert summarise(tmp_path / "c.mcap")["scenario"] is None


def test_replay_uses_the_recorded_scenario_and_names_both_when_told_another(tmp_path) -> None:
    path = tmp_path / "r.mcap"
    urban, dense = (URBAN.name, scenario_fingerprint(URBAN)), (DENSE.name, scenario_fingerprint(DENSE))
    warnings: list[str] = []
    assert replay_scenario(path, None, dense, warnings.append) == "downtown_dense" and warnings == []
    assert replay_scenario(path, "downtown_dense", dense, warnings.append) == "downtown_dense" and warnings == []
    assert replay_scenario(path, "wang2012_urban", dense, warnings.append) == "wang2012_urban"
    assert warnings == [f"{path} was recorded in scenario downtown_dense (fingerprint {dense[1]}); using --scenario "
                        f"wang2012_urban, which is wang2012_urban (fingerprint {urban[1]})"]


def test_replay_says_when_the_recorded_scenario_is_not_the_shipped_one(tmp_path) -> None:
    path = tmp_path / "r.mcap"
    warnings: list[str] = []
    edited = ("wang2012_urban", "0123456789abcdef")  # the same name, other settings
    assert replay_scenario(path, None, edited, warnings.append) == "wang2012_urban"
    assert len(warnings) == 1 and "fingerprint 0123456789abcdef" in warnings[0]
    assert f"the shipped wang2012_urban has other settings (fingerprint {scenario_fingerprint(URBAN)})" in warnings[0]
    with pytest.raises(UsageError, match="scenario my_city .* not a shipped one: give its file with --scenario"):
        replay_scenario(path, None, ("my_city", "0123456789abcdef"), warnings.append)
    warnings.clear()
    assert replay_scenario(path, None, None, warnings.append) == "wang2012_urban"
    assert len(warnings) == 1 and "does not name its scenario" in warnings[0]


def test_processing_a_many_target_recording_takes_its_scenario_from_the_file(tmp_path, capsys, caplog) -> None:
    scenario = load_scenario("multitarget_urban")
    path = tmp_path / "mt.mcap"
    record_scene(scenario, build_world(scenario), path, duration_s=20.0, seed=1)
    with caplog.at_level(logging.WARNING):
        assert main(["replay", str(path), "--process"]) == 0
    out = capsys.readouterr().out
    assert "GOSPA mean" in out and "against every recorded truth" in out  # the many-target scenario's scoring, not one target's RMSE
    assert "not kept: --out TRACKS.csv or .mcap writes them" in out
    assert [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING] == []
    with caplog.at_level(logging.WARNING):
        assert main(["replay", str(path), "--process", "--scenario", "wang2012_urban"]) == 0
    assert "GOSPA" not in capsys.readouterr().out  # told to, it tracks one target
    assert any("recorded in scenario multitarget_urban" in r.getMessage() for r in caplog.records)


def test_a_recording_without_reports_cannot_be_processed(tmp_path, capsys) -> None:
    path = tmp_path / "outputs.mcap"
    with Recorder(path) as recorder:  # what a recorder hears of a daemon without vehicles
        status = DaemonStatus(stamp_ns=S, uptime_s=1.0, scenario="wang2012_urban", vehicles=())
        recorder.write(status_key(), *encode(status), S)
    assert main(["replay", str(path), "--process", "--out", str(tmp_path / "tracks.csv")]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err == [f"gcs replay: error: {path} holds no vehicle report, so there are no tracks to estimate "
                   f"(gcs replay {path} --info lists what it holds)"]
    assert not (tmp_path / "tracks.csv").exists()
    assert main(["replay", str(path), "--info"]) == 0
    assert "no vehicle report: --process has nothing to estimate from" in capsys.readouterr().out
    assert [r.key for r in read_recording(path)] == [status_key()]
