"""Which scenario a recording was made in, and which one ``gcs replay`` uses for it.

A recording names its scenario in the metadata record
:data:`~gcs.adapters.recording.SCENARIO_METADATA` (``gcs run --record`` writes its own;
``gcs record`` the first one a vehicle announced), and in the vehicles' announcements
(:class:`~protocols.messages.VehicleScenario`, on ``<prefix>/vehicle/<id>/scenario``)
recorded with the rest. The first of these found is the recording's scenario: its name
and fingerprint (:func:`gcs.config.fingerprint.scenario_fingerprint`).

``gcs replay`` (:func:`replay_scenario`) uses, in this order:

1. ``--scenario`` when given; when the recording names another scenario (another name or
   fingerprint) it warns, naming both;
2. the recording's scenario when it is shipped under that name; when the shipped one's settings
   differ (another fingerprint) it warns, naming both; a scenario that is not shipped (a file of
   the user's) is an input error asking for ``--scenario FILE.toml``;
3. the default scenario, with a warning, for a recording that names none.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from gcs.adapters.recording import SCENARIO_METADATA, Recorded, read_recording
from gcs.cli_errors import UsageError
from gcs.config.fingerprint import scenario_fingerprint
from gcs.recordings.keys import key_kind
from gcs.scenarios import DEFAULT_SCENARIO, list_scenarios, load_scenario
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.messages import VehicleScenario

__all__ = ["RecordingContents", "ScenarioFinder", "recording_contents", "replay_scenario"]

log = logging.getLogger(__name__)


class ScenarioFinder:
    """Finds a recording's scenario while it is read: hand it the metadata records (:meth:`metadata`, as
    ``read_recording``'s ``on_metadata``) and the records with their key kind (:meth:`see`); :attr:`found` is the
    first scenario (name, fingerprint) named, the metadata's before any announcement, or None."""

    def __init__(self) -> None:
        self.found: tuple[str, str] | None = None
        self._from_metadata = False

    def metadata(self, name: str, data: dict[str, str]) -> None:
        """A metadata record: the recording's scenario if it is :data:`SCENARIO_METADATA` (and the first such)."""
        if name == SCENARIO_METADATA and not self._from_metadata and {"name", "fingerprint"} <= set(data):
            self.found, self._from_metadata = (data["name"], data["fingerprint"]), True

    def see(self, record: Recorded, kind: str | None) -> None:
        """A record of the given key kind: a vehicle's announcement names the scenario if nothing did before."""
        if kind != "scenario" or self.found is not None:
            return
        try:
            announced = decode(record.payload, record.encoding, VehicleScenario)
        except ProtocolError:
            return  # recorded as it came; not one to go by
        self.found = (announced.scenario, announced.fingerprint)


@dataclass(frozen=True)
class RecordingContents:
    """What ``gcs replay`` needs to know before it starts: the recorded scenario (name, fingerprint), if any,
    and whether any vehicle report is in the file."""

    scenario: tuple[str, str] | None
    has_report: bool


def recording_contents(path: Path) -> RecordingContents:
    """The recording's scenario and whether it holds a report, reading only as far as it takes to know both."""
    finder, has_report = ScenarioFinder(), False
    for record in read_recording(path, warn=lambda _: None, on_metadata=finder.metadata):  # the reading proper warns
        kind, _ = key_kind(record.key)
        has_report = has_report or kind == "report"
        finder.see(record, kind)
        if finder.found is not None and has_report:
            break
    return RecordingContents(finder.found, has_report)


def _named(scenario: tuple[str, str]) -> str:
    return f"{scenario[0]} (fingerprint {scenario[1]})"


def replay_scenario(path: Path, given: str | None, recorded: tuple[str, str] | None,
                    warn: Callable[[str], None] = log.warning) -> str:
    """The scenario (a shipped name or a file) to replay ``path`` with; see the module docstring.
    UsageError for a recorded scenario that is not shipped when ``given`` is None."""
    if given is not None:
        chosen = load_scenario(given)
        ours = (chosen.name, scenario_fingerprint(chosen))
        if recorded is not None and recorded != ours:
            warn(f"{path} was recorded in scenario {_named(recorded)}; using --scenario {given}, which is "
                 f"{_named(ours)}")
        return given
    if recorded is None:
        warn(f"{path} does not name its scenario (no vehicle announced one while it was recorded): using "
             f"{DEFAULT_SCENARIO}; give --scenario NAME_OR_FILE for another")
        return DEFAULT_SCENARIO
    name = recorded[0]
    if name not in list_scenarios():
        raise UsageError(f"{path} was recorded in scenario {_named(recorded)}, which is not a shipped one: give its "
                         "file with --scenario FILE.toml")
    shipped = (name, scenario_fingerprint(load_scenario(name)))
    if shipped != recorded:
        warn(f"{path} was recorded in scenario {_named(recorded)}, but the shipped {name} has other settings "
             f"(fingerprint {shipped[1]}): using the shipped one; give --scenario FILE.toml with the recorded settings "
             "to replay them")
    return name
