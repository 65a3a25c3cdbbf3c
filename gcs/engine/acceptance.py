"""The engine's acceptance of its inputs: what arrived is validated and counted, the vehicles' registry kept,
their reports gathered into decision steps and their navigation run, and the set of vehicles alive answered.

:meth:`Acceptance.arrived` takes one :class:`~gcs.engine.events.Arrived`: a liveliness change updates
the registry (a roster vehicle) or the observers' tokens (``accept_unlisted``); a sample is
validated (:class:`~gcs.engine.ingest.Ingest`) and, when accepted, goes to the registry, the step
assembler (:class:`~gcs.engine.steps.StepAssembler`, reorder window ``max_wait_s``) and the
navigator (:func:`~gcs.engine.navigation.navigator_for`). :meth:`Acceptance.alive` is what a step
waits for: the roster's vehicles alive (liveliness token or MAVLink heartbeat) and the observers
accepted whose token is declared.
"""

from __future__ import annotations

import logging

from gcs.config import Scenario
from gcs.engine.events import Arrived, Heartbeat
from gcs.engine.ingest import MAX_UNLISTED, Ingest
from gcs.engine.navigation import navigator_for
from gcs.engine.options import EngineOptions
from gcs.engine.registry import Registry
from gcs.engine.steps import StepAssembler
from protocols.keys import parse_key
from protocols.messages import NavReport, SensorReport, TargetTruth, VehicleScenario

__all__ = ["Acceptance", "ALIVE_REFRESH_S", "MAX_OBSERVER_TOKENS", "NS_PER_S"]

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
MAX_OBSERVER_TOKENS = 4 * MAX_UNLISTED
"""Liveliness tokens of vehicles outside the roster remembered (``accept_unlisted``); a flood of made-up
tokens cannot grow the set beyond this."""
ALIVE_REFRESH_S = 0.02
"""How long the engine reuses the set of vehicles alive when no liveliness change came in between.

A liveliness token declared or withdrawn is seen at once; what changes without a
liveliness sample (a MAVLink heartbeat that arrives, or one that ages past
``LOST_AFTER_S``, 5 s) is seen within this. Asking every vehicle on every pass
cost the loop a quarter of its time at 100 vehicles, where a pass handles a report
or two."""


class Acceptance:
    """Validation, registry, step assembly, navigation and the vehicles alive (see the module docstring)."""

    def __init__(self, scenario: Scenario, options: EngineOptions) -> None:
        self.options = options
        self.roster = [v.id for v in scenario.vehicles]
        self.ingest = Ingest(set(self.roster), options.prefix, options.accept_unlisted, scenario)
        self.steps = StepAssembler(round(scenario.time.step_s * NS_PER_S), options.max_wait_s)
        self.navigator = navigator_for(options.navigation, scenario)
        self.registry = Registry(list(scenario.vehicles), self._heartbeat_age)
        self._heard_s: dict[str, float] = {}
        self._alive_now: frozenset[str] | None = None  # the vehicles alive (see alive), asked at _alive_since_s
        self._alive_since_s = 0.0
        self._observer_tokens: set[str] = set()

    def heartbeat(self, event: Heartbeat) -> None:
        """A roster vehicle's MAVLink heartbeat (others are ignored)."""
        if event.vehicle_id in self.registry.entries:
            self._heard_s[event.vehicle_id] = event.heard_s

    def _heartbeat_age(self, vehicle_id: str, now_s: float) -> float | None:
        heard = self._heard_s.get(vehicle_id)
        return None if heard is None else now_s - heard

    def arrived(self, item: Arrived) -> SensorReport | NavReport | TargetTruth | VehicleScenario | None:
        """Take one input as it arrived; the message accepted, if it is one (None for a liveliness change)."""
        now = item.now_s
        if item.kind in ("alive", "gone"):
            try:
                parsed = parse_key(item.key, self.options.prefix)
            except ValueError:
                self.ingest.reject("key", f"liveliness key {item.key!r}")
                return None
            if parsed.kind != "alive" or parsed.ident is None:  # (parse_key names every alive key's vehicle)
                return None
            if parsed.ident in self.registry.entries:
                self.registry.on_liveliness(parsed.ident, item.kind == "alive", now)
                self._alive_now = None
                log.info("vehicle %s %s", parsed.ident, "joined" if item.kind == "alive" else "left")
            elif self.options.accept_unlisted:
                self._observer_token(parsed.ident, item.kind == "alive")
            return None
        admitted = len(self.ingest.unlisted)
        message = self.ingest.accept(item)
        if len(self.ingest.unlisted) != admitted:  # a new observer: steps wait for it if its token is declared
            self._alive_now = None
        if isinstance(message, SensorReport):
            if message.vehicle_id in self.registry.entries:  # else a vehicle outside the roster (accept_unlisted)
                self.registry.on_report(message)
            self.steps.add(message, now)
        elif isinstance(message, NavReport):
            if message.vehicle_id in self.registry.entries:
                self.registry.on_nav(message)
                if self.navigator is not None:
                    self.navigator.add(message)
                    self.steps.add_nav(message.vehicle_id, message.stamp_ns)
        return message

    def _observer_token(self, vehicle_id: str, declared: bool) -> None:
        """The liveliness token of a vehicle outside the roster (kept for at most :data:`MAX_OBSERVER_TOKENS`)."""
        if declared and len(self._observer_tokens) < MAX_OBSERVER_TOKENS:
            self._observer_tokens.add(vehicle_id)
        elif not declared:
            self._observer_tokens.discard(vehicle_id)
        self._alive_now = None

    def alive(self, now_s: float) -> frozenset[str]:
        """The vehicles a step waits for: the roster's alive now (liveliness token or MAVLink heartbeat) and,
        with ``accept_unlisted``, the observers accepted whose token is declared (their reports are fused:
        whether one is in its step must not depend on when it arrived). Asked again after a liveliness
        change or a new observer, or :data:`ALIVE_REFRESH_S` after the last time."""
        if self._alive_now is None or not self._alive_since_s <= now_s < self._alive_since_s + ALIVE_REFRESH_S:
            self._alive_now = frozenset([vid for vid in self.roster if self.registry.alive(vid, now_s)]
                                        + [vid for vid in self.ingest.unlisted if vid in self._observer_tokens])
            self._alive_since_s = now_s
        return self._alive_now
