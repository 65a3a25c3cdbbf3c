"""A scenario's fingerprint: which settings it holds, in 16 hex digits.

The fingerprint is the first :data:`FINGERPRINT_DIGITS` hex digits of the SHA-256 of the
scenario's canonical JSON: the decoded :class:`~gcs.config.Scenario` with every default
filled in and object keys sorted (``msgspec.json.encode(scenario, order="sorted")``). So
comments, key order, spacing and whether a default is spelled out do not change it; any
setting does, and so does the name and the description. Files a scenario names (a GeoJSON
city, a target's path) enter by their names, not their content.

Vehicles announce it with their scenario's name (:class:`protocols.VehicleScenario`), and
recordings keep it, so that two scenarios of one name but other settings are told apart.
"""

from __future__ import annotations

import hashlib

import msgspec

from gcs.config import Scenario

__all__ = ["FINGERPRINT_DIGITS", "scenario_fingerprint"]

FINGERPRINT_DIGITS = 16
"""Hex digits kept of the SHA-256 (64 bits: two different scenarios share one with odds of 1 in 2**64)."""


def _plain(value: object) -> object:
    """A NumPy scalar (a scenario built in code may hold one) as the Python number it equals."""
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"a scenario holds a {type(value).__name__}, which has no JSON form")


def scenario_fingerprint(scenario: Scenario) -> str:
    """The fingerprint of ``scenario``'s settings; see the module docstring."""
    canonical = msgspec.json.encode(scenario, order="sorted", enc_hook=_plain)
    return hashlib.sha256(canonical).hexdigest()[:FINGERPRINT_DIGITS]
