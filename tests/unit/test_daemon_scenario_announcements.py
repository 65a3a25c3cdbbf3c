"""The daemon's ingest checks the scenario each vehicle announces against its own, and warns once per other one."""

from __future__ import annotations

import logging

from gcs.adapters.zenoh_io import Received
from gcs.config.fingerprint import scenario_fingerprint
from gcs.engine.ingest import Ingest
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import scenario_key
from protocols.messages import VehicleScenario

OWN = load_scenario("wang2012_urban")
OTHER = load_scenario("downtown_dense")


def _announced(vehicle: str, name: str, fingerprint: str, key_vehicle: str | None = None) -> Received:
    message = VehicleScenario(vehicle_id=vehicle, stamp_ns=1, scenario=name, fingerprint=fingerprint)
    return Received("sample", scenario_key(key_vehicle or vehicle), *encode(message), 0)


def _warnings(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]


def test_the_same_scenario_passes_quietly(caplog) -> None:
    ingest = Ingest({v.id for v in OWN.vehicles}, scenario=OWN)
    with caplog.at_level(logging.WARNING):
        for vehicle in ("uav1", "uav2", "uav3"):
            message = ingest.accept(_announced(vehicle, OWN.name, scenario_fingerprint(OWN)))
            assert message is not None and message.vehicle_id == vehicle
    assert ingest.counters == {"accepted.scenario": 3} and ingest.foreign_scenarios == set()
    assert _warnings(caplog) == []


def test_another_scenario_is_warned_about_once_naming_both(caplog) -> None:
    ingest = Ingest({v.id for v in OWN.vehicles}, scenario=OWN)
    theirs, ours = scenario_fingerprint(OTHER), scenario_fingerprint(OWN)
    with caplog.at_level(logging.WARNING):
        for _ in range(3):  # announced once a second: one warning for the lot
            for vehicle in [v.id for v in OTHER.vehicles]:  # another roster too: announced all the same
                ingest.accept(_announced(vehicle, OTHER.name, theirs))
    assert _warnings(caplog) == [
        f"vehicle {OTHER.vehicles[0].id} flies scenario downtown_dense (fingerprint {theirs}), but this daemon runs "
        f"wang2012_urban (fingerprint {ours}): start the daemon and the vehicles with the same --scenario"]
    assert ingest.counters["accepted.scenario"] == 3 * len(OTHER.vehicles)


def test_the_same_name_with_other_settings_is_another_scenario(caplog) -> None:
    ingest = Ingest({v.id for v in OWN.vehicles}, scenario=OWN)
    with caplog.at_level(logging.WARNING):
        ingest.accept(_announced("uav1", OWN.name, "0123456789abcdef"))
        ingest.accept(_announced("uav2", OWN.name, "fedcba9876543210"))
    warnings = _warnings(caplog)
    assert len(warnings) == 2 and all("flies scenario wang2012_urban (fingerprint" in w for w in warnings)
    assert "0123456789abcdef" in warnings[0] and "fedcba9876543210" in warnings[1]


def test_a_bad_announcement_is_rejected_and_counted(caplog) -> None:
    ingest = Ingest({v.id for v in OWN.vehicles}, scenario=OWN)
    assert ingest.accept(_announced("uav1", OTHER.name, "0123456789abcdef", key_vehicle="uav2")) is None
    garbled = Received("sample", scenario_key("uav1"), b'{"vehicle_id": "uav1"}',
                       "application/json;gcs.VehicleScenario/1", 0)
    assert ingest.accept(garbled) is None
    assert ingest.counters == {"rejected.id_mismatch": 1, "rejected.invalid": 1}
    assert ingest.foreign_scenarios == set()  # nothing taken from a message that was refused


def test_without_its_own_scenario_nothing_is_compared(caplog) -> None:
    ingest = Ingest({"uav1"})
    with caplog.at_level(logging.WARNING):
        assert ingest.accept(_announced("uav1", OTHER.name, scenario_fingerprint(OTHER))) is not None
    assert _warnings(caplog) == [] and ingest.counters == {"accepted.scenario": 1}
