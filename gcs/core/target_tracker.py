"""The one interface of the trackers: a scan of every vehicle's detections turns a tracker's state into the next.

Both trackers the engine runs implement :class:`TargetTracker`:

* the single-target tracker (:class:`gcs.core.single_target.SingleTargetTracker`): the state is
  one estimate (None before the first detection); of each vehicle's detections it fuses the
  one nearest the track (wang2012 eq. 14-15, the DUIF);
* the multi-target tracker (:class:`gcs.core.multitarget.MultiTargetTracker`): the state is a
  set of tracks; every detection is associated (GNN or JPDA), tracks are confirmed and deleted.

A tracker holds parameters, never the state: :meth:`TargetTracker.start` gives the state before
any scan, :meth:`TargetTracker.scan` the state after one and what happened in it, and mutates
nothing. ``detections_by_vehicle`` maps a vehicle's index to its detections of the scan (those of
a vehicle index ``sensors``); ``in_view`` says which predicted ground positions (T, 2) some
vehicle's sensor covered on the scan (None: all of them), for a tracker that counts misses.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.sensor import SensorModel
from gcs.core.tracker import Detection

__all__ = ["TargetTracker", "DetectionsByVehicle", "InView"]

StateT = TypeVar("StateT")
DiagnosticsT = TypeVar("DiagnosticsT", covariant=True)

DetectionsByVehicle = Mapping[int, Sequence[Detection]]
"""A scan's detections: vehicle index (into the sensors) -> that vehicle's detections, in the vehicles' order."""
InView = Callable[[NDArray[np.float64]], NDArray[np.bool_]]
"""Ground positions (T, 2) -> whether some vehicle's sensor covered each on the scan (T,)."""


class TargetTracker(Protocol[StateT, DiagnosticsT]):
    """What the engine asks of a tracker, one target or many (see the module docstring)."""

    def start(self) -> StateT:
        """The state before the first scan."""
        ...

    def scan(self, state: StateT, stamp_ns: int, detections_by_vehicle: DetectionsByVehicle,
             sensors: Sequence[SensorModel], in_view: InView | None = None, /) -> tuple[StateT, DiagnosticsT]:
        """The state after one scan at ``stamp_ns`` (int, ns), and what happened in it."""
        ...
