"""Scenario files shipped with the package, and the loader for any scenario file.

``load_scenario("wang2012_urban")`` loads a shipped scenario by name;
``load_scenario("path/to/my.toml")`` loads a file. Either way the result is a
validated, frozen :class:`gcs.config.Scenario`, or a :class:`ScenarioError`
whose message names the file and the bad key.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import msgspec

from gcs.config import Scenario, ScenarioError, validate_scenario

__all__ = ["DEFAULT_SCENARIO", "list_scenarios", "load_scenario", "parse_scenario", "scenario_base_dir"]

DEFAULT_SCENARIO = "wang2012_urban"


def list_scenarios() -> list[str]:
    """Names of the scenarios shipped as package data, sorted."""
    files = resources.files(__name__).iterdir()
    return sorted(Path(f.name).stem for f in files if f.name.endswith(".toml"))


def parse_scenario(text: bytes | str, source: str = "<scenario>") -> Scenario:
    """Decode and validate scenario TOML; errors name ``source`` and the key path."""
    try:
        scenario = msgspec.toml.decode(text, type=Scenario)
    except msgspec.ValidationError as exc:
        raise ScenarioError(f"{source}: {_path_first(str(exc))}") from None
    except msgspec.DecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    try:
        return validate_scenario(scenario)
    except ScenarioError as exc:
        raise ScenarioError(f"{source}: {exc}") from None


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a shipped scenario by name, or any scenario file by path."""
    text = str(name_or_path)
    candidate = Path(text)
    if candidate.suffix == ".toml" or candidate.exists():
        try:
            return parse_scenario(candidate.read_bytes(), source=str(candidate))
        except OSError as exc:
            raise ScenarioError(f"{candidate}: cannot read scenario file: {exc.strerror}") from None
    shipped = resources.files(__name__) / f"{text}.toml"
    if not shipped.is_file():
        known = ", ".join(list_scenarios())
        raise ScenarioError(f"unknown scenario {text!r}: give a .toml path or one of: {known}")
    return parse_scenario(shipped.read_bytes(), source=f"{text}.toml")


def scenario_base_dir(name_or_path: str | Path) -> Path | None:
    """Folder that a scenario file's relative paths are resolved against: the file's own, or for a shipped
    name the shipped scenarios' folder (where its GeoJSON files are); None for a name that is neither."""
    candidate = Path(str(name_or_path))
    if candidate.suffix == ".toml" or candidate.exists():
        return candidate.resolve().parent
    shipped = resources.files(__name__)
    if (shipped / f"{candidate}.toml").is_file():
        return Path(str(shipped))
    return None


def _path_first(message: str) -> str:
    """Turn msgspec's ``"Expected ... - at `$.a.b`"`` into ``"$.a.b: Expected ..."``."""
    text, sep, path = message.rpartition(" - at `")
    if not sep:
        return f"$: {message}"
    return f"{path.rstrip('`')}: {text}"
