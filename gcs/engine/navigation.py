"""Every roster vehicle's own position from its ``NavReport``s: feng2019's SKF, in stamp order, for the daemon and replay.

The daemon (:mod:`gcs.daemon.app`) and ``gcs replay --process`` (:mod:`gcs.recordings.replay`) hold one
:class:`FleetNavigator` and drive it the same way, so that the position a detection is
fused with does not depend on when the nav reports arrived:

* :meth:`FleetNavigator.add` buffers every accepted nav report of a roster vehicle;
* :meth:`FleetNavigator.advance_to` ``(T_k)``, called when decision step ``k`` is released
  and before it is fused, applies, per vehicle and in stamp order (ties by ``seq``), every
  buffered report stamped ``<= T_k`` (feng2019's SKF without a route, which is one extended
  Kalman filter: :func:`gcs.core.navigation.skf.gaussian_update`; INS increments, eq. 1,
  then the GPS fix, eq. 4-5, with the GNSS velocity and heading);
* :meth:`FleetNavigator.position_at` gives a vehicle's horizontal position at a stamp
  (extrapolated by eq. 6 from its last applied report) with its covariance.

The step assembler (:mod:`gcs.engine.steps`) releases step ``k`` only once every expected
vehicle that sends nav (at least once a step) has sent one stamped ``>= T_k`` (or the step
times out), so every report stamped ``<= T_k`` is in the buffer by then. A report stamped at or before a step
already advanced to is **late**: counted as ``rejected.late_nav``, logged at DEBUG and
dropped, never applied out of order. The filter state when step ``k`` is fused is then a
function of the reports' stamps alone, as live so in replay.

A vehicle's filter starts at its first report with a GPS fix (``fix_type >= 2``), about the
fix with ``h_acc_m`` per axis, heading from the report's ``heading_rad`` or else its
velocity (``nav.waiting_for_fix`` counts the reports before it). A report the filter
refuses (the update raises, its result is not finite, or its position is further than
ingest's :data:`~gcs.engine.ingest.MAX_ABS_POSITION_M` from the origin) is counted as
``rejected.nav_update`` and the estimate stays as it was. An estimate more than
:data:`MAX_EXTRAPOLATION_S` older than the detection (the vehicle's nav stopped) is not
used: the detection falls back to the report's own position (``nav.stale``).

**GPS bias.** The filter takes every fix's error as white (eq. 4), so averaging 5 fixes
a second brings its covariance far below a GPS's slowly wandering bias, which no
averaging removes. :meth:`FleetNavigator.position_at` adds the bias variance
``gps_bias_std_m^2`` per horizontal axis (the scenario's ``[simulation.gps] bias_std_m``,
as the INS figures are taken for a datasheet) to the covariance it gives the target
filter. Over 300 s of the default scenario's loitering vehicles with ``x < 1200 m`` GPS-denied
(seeds 1-3), the mean normalised error squared of the horizontal positions was 8-11 with a
fix without this term (2 is consistent), 1.6-2.2 with it, and 3.4-4.5 without a fix (the
INS's scale error and gyro drift are biases the filter allows for only as white noise).

**Altitude.** The SKF is horizontal (feng2019's state ``[x, y, theta, vx, vy, vtheta]``).
The vertical of a detection is the vehicle's own altitude in its ``SensorReport``
(``vehicle_position_enu_m[2]``, measured at the detection's stamp); its variance is
``v_acc_m^2`` of the GPS fix of the last applied nav report when that report had a fix (the
vehicle's altitude is then the fix's), and 0 without one: a vehicle without GPS holds its
altitude by barometer, whose accuracy a ``NavReport`` does not carry, and the target
filter takes an unreported vertical as exact, as before this filter.

**Route.** No map observations: the commanded path is not given as a route. It says how far
a vehicle moved, not where it is, and makes the filter overconfident (``nav_update``'s
docstring); against ``sim-vehicles``, whose autopilot steers
with its true position, it would even carry absolute information a real one in a
GPS-denied zone would not have. The daemon's navigation is GPS + INS.

Index conventions: covariances are ENU ``(x, y, z)``, m^2; stamps are integer ns.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario
from gcs.core.geometry import LocalFrame
from gcs.engine.ingest import MAX_ABS_POSITION_M
from gcs.core.navigation.fleet_ekf import gaussian_updates
from gcs.core.navigation.skf import (NavGaussian, NavMeasurement, NavParams, initial, nav_measurements,
                                     position_at)
from protocols.messages import NavReport

__all__ = ["NAVIGATION_MODES", "FleetNavigator", "navigator_for", "runs_skf", "MAX_BUFFERED", "MIN_HEADING_SPEED_MPS",
           "MAX_EXTRAPOLATION_S"]

log = logging.getLogger(__name__)

NAVIGATION_MODES = ("auto", "skf", "reported")
"""``skf``: detections from this module's estimate; ``reported``: the ``SensorReport``'s own position, exact;
``auto`` (the default): ``skf`` for a scenario that declares GPS-denied zones, else ``reported``
(:func:`navigator_for`)."""
NS_PER_S = 1_000_000_000
MAX_BUFFERED = 1024
"""Reports buffered per vehicle (about 200 s at 5 Hz); beyond, the oldest is applied at once (``nav.applied_early``)
so that a vehicle that sends nav but no reports cannot grow the buffer without bound."""
MAX_EXTRAPOLATION_S = 5.0
"""Longest extrapolation of an estimate to a detection's stamp (nav at 5 Hz needs 0.2 s; 5 s: its nav stopped)."""
MIN_HEADING_SPEED_MPS = 1.0
"""Slowest velocity whose direction is taken for the initial heading."""


class FleetNavigator:
    """One SKF per roster vehicle, fed in stamp order; see the module docstring.

    Parameters
    ----------
    roster : sequence of str
        The vehicles navigated (reports of others are ignored, counted as ``nav.unlisted``).
    params : NavParams
        The filter's parameters (:meth:`NavParams.from_scenario`).
    frame : LocalFrame
        The scenario's ENU frame (GPS fixes are geodetic).
    gps_bias_std_m : float
        1-sigma of the GPS's slowly varying bias per horizontal axis, m (module docstring).
    """

    def __init__(self, roster: Sequence[str], params: NavParams, frame: LocalFrame, gps_bias_std_m: float = 0.0
                 ) -> None:
        if not gps_bias_std_m >= 0.0:
            raise ValueError(f"gps_bias_std_m must be >= 0, got {gps_bias_std_m!r}")
        self.roster = tuple(roster)
        self.params, self.frame = params, frame
        self.gps_bias_var_m2 = float(gps_bias_std_m) ** 2
        self.counters: Counter[str] = Counter()
        self.advanced_ns: int | None = None
        self.senders: set[str] = set()
        self._pending: dict[str, list[tuple[int, int, int, NavReport]]] = {v: [] for v in self.roster}
        self._estimates: dict[str, NavGaussian] = {}
        self._vertical_var: dict[str, float] = {}
        self._fix: dict[str, bool] = {}
        self._arrival = itertools.count()

    @classmethod
    def from_scenario(cls, scenario: Scenario, roster: Sequence[str] | None = None) -> FleetNavigator:
        """The navigator for a scenario's vehicles (the INS figures of ``[simulation.ins]`` as their datasheet)."""
        frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
        return cls([v.id for v in scenario.vehicles] if roster is None else roster, NavParams.from_scenario(scenario),
                   frame, scenario.simulation.gps.bias_std_m)

    # ------------------------------------------------------------------ input

    def add(self, nav: NavReport) -> bool:
        """Buffer an accepted nav report; False (counted) when it is late or from outside the roster."""
        pending = self._pending.get(nav.vehicle_id)
        if pending is None:
            self.counters["nav.unlisted"] += 1
            return False
        if self.advanced_ns is not None and nav.stamp_ns <= self.advanced_ns:
            self.counters["rejected.late_nav"] += 1
            log.debug("nav report %s/%d at %d ns is late (step at %d ns already fused): dropped", nav.vehicle_id,
                      nav.seq, nav.stamp_ns, self.advanced_ns)
            return False
        self.senders.add(nav.vehicle_id)
        # (stamp, seq) orders the reports; the arrival count only breaks a tie ingest never lets through.
        heapq.heappush(pending, (nav.stamp_ns, nav.seq, next(self._arrival), nav))
        if len(pending) > MAX_BUFFERED:
            self.counters["nav.applied_early"] += 1
            self._apply([heapq.heappop(pending)[3]])
        return True

    def advance_to(self, stamp_ns: int) -> None:
        """Apply, vehicle by vehicle in stamp order, every buffered report stamped ``<= stamp_ns``.

        The reports go in rounds, the r-th due report of every vehicle in round r,
        each round's vehicles updated together (:func:`gcs.core.navigation.fleet_ekf.gaussian_updates`:
        a vehicle's result does not depend on the others'). Later calls with an earlier
        stamp apply nothing; the navigator never goes back.
        """
        due: list[list[NavReport]] = []
        for vehicle_id in self.roster:
            pending = self._pending[vehicle_id]
            reports = []
            while pending and pending[0][0] <= stamp_ns:
                reports.append(heapq.heappop(pending)[3])
            if reports:
                due.append(reports)
        for rank in range(max((len(reports) for reports in due), default=0)):
            self._apply([reports[rank] for reports in due if len(reports) > rank])
        self.advanced_ns = stamp_ns if self.advanced_ns is None else max(self.advanced_ns, stamp_ns)

    def _apply(self, navs: list[NavReport]) -> None:
        """One report of each of several vehicles into their filters; whatever they hold, nothing raises."""
        try:
            measurements = nav_measurements(navs, self.frame)
        except (ValueError, ArithmeticError) as error:  # ingest checked them: one at a time to find the bad one
            if len(navs) == 1:
                self._refused(navs[0], error)
                return
            for nav in navs:
                self._apply([nav])
            return
        updating = [i for i, nav in enumerate(navs) if nav.vehicle_id in self._estimates]
        updated = dict(zip(updating, gaussian_updates(self.params, [self._estimates[navs[i].vehicle_id] for i in updating],
                                                      [measurements[i] for i in updating])))
        for i, (nav, measurement) in enumerate(zip(navs, measurements)):
            new = updated.get(i)
            try:
                if new is None:
                    gps_fix = measurement.gps_fix
                    if gps_fix is None:
                        self.counters["nav.waiting_for_fix"] += 1
                        continue
                    new = self._initial(nav, measurement, gps_fix)
                if isinstance(new, Exception):
                    raise new
                if not (np.all(np.isfinite(new.mean)) and np.all(np.isfinite(new.cov))):
                    raise ValueError("the navigation estimate is not finite")
                if not np.all(np.abs(new.mean[:2]) <= MAX_ABS_POSITION_M):
                    raise ValueError(f"position {new.mean[:2]} m is beyond {MAX_ABS_POSITION_M:g} m of the origin")
            except (ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
                self._refused(nav, error)
                continue
            self._estimates[nav.vehicle_id] = new
            fix = measurement.gps_xy is not None  # nav_measurement keeps a fix of MIN_GPS_FIX or better
            self._fix[nav.vehicle_id] = fix
            self._vertical_var[nav.vehicle_id] = float(nav.gps.v_acc_m) ** 2 if fix and nav.gps is not None else 0.0
            self.counters["nav.applied"] += 1

    def _refused(self, nav: NavReport, error: Exception) -> None:
        self.counters["rejected.nav_update"] += 1
        log.debug("nav report %s/%d at %d ns refused: %s", nav.vehicle_id, nav.seq, nav.stamp_ns, error)

    def _initial(self, nav: NavReport, measurement: NavMeasurement,
                 gps_fix: tuple[NDArray[np.float64], float]) -> NavGaussian:
        """The first estimate: the fix, the reported heading or the velocity's direction (else unknown)."""
        params, heading = self.params, nav.heading_rad
        velocity = measurement.velocity_xy
        if heading is None and velocity is not None and math.hypot(*velocity) >= MIN_HEADING_SPEED_MPS:
            heading = math.atan2(velocity[1], velocity[0])
        if heading is None:  # no idea which way it points: a heading spread of pi
            params, heading = replace(params, initial_heading_std_rad=math.pi), 0.0
        first = initial(params, measurement.stamp_ns, gps_fix[0], gps_fix[1], heading, velocity)
        return NavGaussian(first.stamp_ns, first.mean, first.cov)

    # ----------------------------------------------------------------- output

    def position_at(self, vehicle_id: str, stamp_ns: int) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """The vehicle's horizontal position (2,) at ``stamp_ns`` and its (3, 3) ENU covariance; None before a fix.

        Extrapolated by eq. (6) from the last applied report when ``stamp_ns`` is later (a stamp
        before it gives the estimate itself). The horizontal block is the filter's plus the GPS
        bias variance, ``cov[2, 2]`` the vertical variance (module docstring); the vertical is
        uncorrelated with the horizontal.
        """
        estimate = self._estimates.get(vehicle_id)
        if estimate is None:
            return None
        if stamp_ns - estimate.stamp_ns > MAX_EXTRAPOLATION_S * NS_PER_S:
            self.counters["nav.stale"] += 1
            return None
        xy, cov_xy = position_at(self.params, estimate, stamp_ns)
        cov = np.zeros((3, 3))
        cov[:2, :2] = cov_xy + self.gps_bias_var_m2 * np.eye(2)
        cov[2, 2] = self._vertical_var[vehicle_id]
        return xy, cov

    def horizontal_std_m(self, vehicle_id: str) -> float | None:
        """1-sigma of the last applied estimate along its worst horizontal axis, GPS bias included, m
        (None before a fix)."""
        estimate = self._estimates.get(vehicle_id)
        if estimate is None:
            return None
        cov = estimate.cov[:2, :2] + self.gps_bias_var_m2 * np.eye(2)
        return float(math.sqrt(max(np.linalg.eigvalsh(cov).max(), 0.0)))

    def has_fix(self, vehicle_id: str) -> bool | None:
        """Whether the last applied report had a GPS fix (None before a fix)."""
        return self._fix.get(vehicle_id)

    def buffered(self, vehicle_id: str) -> int:
        """Reports waiting for their step."""
        return len(self._pending[vehicle_id])


def navigator_for(mode: str, scenario: Scenario) -> FleetNavigator | None:
    """The navigator a ``--navigation`` mode asks for on a scenario (None: the reported positions).

    ``auto`` runs the SKF where its estimate and covariance count: in a scenario that
    declares GPS-denied zones, where a vehicle's own position degrades while it flies
    on its INS. Elsewhere the vehicles' reported positions (their autopilots' own
    navigation) gave the target filter the same accuracy at a fraction of the cost
    (``docs/benchmarks.md``: target RMSE within 1 m either way; 0.15 ms per nav report).
    """
    return FleetNavigator.from_scenario(scenario) if runs_skf(mode, scenario) else None


def runs_skf(mode: str, scenario: Scenario) -> bool:
    """Whether ``--navigation mode`` runs the SKF on ``scenario`` (:func:`navigator_for`); ValueError
    for an unknown mode."""
    if mode not in NAVIGATION_MODES:
        raise ValueError(f"unknown navigation {mode!r}; expected one of {', '.join(NAVIGATION_MODES)}")
    return mode == "skf" or (mode == "auto" and bool(scenario.gps_denied))
