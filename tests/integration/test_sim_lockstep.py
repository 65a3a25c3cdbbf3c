"""``sim-vehicles run --lockstep``: vehicles flown by several processes keep one clock when one falls behind.

Two runners (threads here, each with its own Zenoh client session, as two
processes would be) fly uav1 and uav2 of the default scenario through a router
on 127.0.0.1; uav2's loop is slowed to a tenth of the asked rate, as a process
starved of CPU would be. An observer on the same router records the order in
which the reports arrive: with lockstep uav1's newest report is never more than
one report period ahead of uav2's.
"""

from __future__ import annotations

import threading
import time
from dataclasses import replace

import msgspec
import pytest
import zenoh

from gcs.adapters.zenoh_session import ZenohSettings, listening_endpoints, open_session
from protocols.keys import alive_selector, parse_key, reports_selector
from protocols.messages import SensorReport
from sim_vehicles.run_options import RunOptions
from sim_vehicles.runner import Runner
from tests.integration.sim_harness import SCENARIO, WORLD
from tests.loopback import LOCALHOST

RATE = 20.0
SLOW_S = 0.02
"""Extra wall seconds each of uav2's physics steps takes (a step is 2.5 ms at 20x): about a tenth of the rate."""
PERIOD_NS = 1_000_000_000  # the scenario's 1 Hz reports


class _Run:
    """A runner in a thread (``slow``: each physics step costs :data:`SLOW_S` more); :meth:`join` waits for it
    and raises its error."""

    def __init__(self, options: RunOptions, slow: bool = False) -> None:
        self.runner = Runner(SCENARIO, WORLD, options)
        if slow:
            advance = self.runner.scene.advance

            def starved(dt: float, guidance: dict) -> None:
                time.sleep(SLOW_S)  # the CPU it does not get
                advance(dt, guidance)

            self.runner.scene.advance = starved
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            self.runner.run()
        except BaseException as error:  # noqa: BLE001 - raised in the test's thread by join()
            self.error = error

    def join(self) -> None:
        self.thread.join(60)
        if self.thread.is_alive():
            self.runner.stop()
            self.thread.join(10)
            pytest.fail("a runner did not finish")
        if self.error is not None:
            raise self.error


@pytest.fixture
def router():
    """A router on a port the system chose; yields its endpoint."""
    session = open_session(ZenohSettings(mode="router", listen=(f"tcp/{LOCALHOST}:0",), connect=()))
    try:
        (endpoint,) = listening_endpoints(session)
        yield endpoint
    finally:
        session.close()


class _Observer:
    """A client of the router recording every report's (vehicle, stamp) in order of arrival, and for each vehicle
    whose liveliness token came up how many reports had arrived before it; closed on exit."""

    def __init__(self, endpoint: str) -> None:
        self.arrivals: list[tuple[str, int]] = []
        self.reports_before_token: dict[str, int] = {}
        self._changed = threading.Condition()
        self._session = open_session(ZenohSettings(mode="client", connect=(endpoint,)))
        self._session.declare_subscriber(reports_selector(), self._on_sample)
        self._session.liveliness().declare_subscriber(alive_selector(), self._on_token)

    def _on_token(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            with self._changed:
                self.reports_before_token[parse_key(str(sample.key_expr)).ident] = len(self.arrivals)
                self._changed.notify_all()

    def _on_sample(self, sample: zenoh.Sample) -> None:
        report = msgspec.json.decode(sample.payload.to_bytes(), type=SensorReport)
        with self._changed:
            self.arrivals.append((report.vehicle_id, report.stamp_ns))
            self._changed.notify_all()

    def wait(self, condition, what: str, timeout_s: float = 60.0) -> list[tuple[str, int]]:
        """The arrivals once ``condition(arrivals)`` holds; AssertionError naming ``what`` after ``timeout_s``."""
        with self._changed:
            assert self._changed.wait_for(lambda: condition(self.arrivals), timeout=timeout_s), (what, self.arrivals)
            return list(self.arrivals)

    def wait_for_token(self, vehicle: str, timeout_s: float = 60.0) -> None:
        with self._changed:
            assert self._changed.wait_for(lambda: vehicle in self.reports_before_token, timeout=timeout_s), vehicle

    def __enter__(self) -> _Observer:
        return self

    def __exit__(self, *exc) -> None:
        self._session.close()


def _options(endpoint: str, lockstep: bool, duration_s: float) -> RunOptions:
    return RunOptions(rate=RATE, duration_s=duration_s, seed=2, epoch_ns=0, lockstep=lockstep,
                      zenoh=ZenohSettings(mode="client", connect=(endpoint,)))


def _fly(endpoint: str, lockstep: bool, reports: int = 8) -> list[tuple[str, int]]:
    """uav1 at full speed and uav2 slowed, on one clock, for ``reports`` report periods; every report in its
    order of arrival at an observer on the router."""
    with _Observer(endpoint) as observer:
        base = _options(endpoint, lockstep, float(reports))  # one clock, started once both are connected
        runs = [_Run(replace(base, only=("uav1",), start_with=("uav2",))),
                _Run(replace(base, only=("uav2",), start_with=("uav1",)), slow=True)]
        for run in runs:
            run.join()
        return observer.wait(lambda seen: len(seen) >= 2 * reports, "the last reports")  # on their way


def _lead_of_uav1(arrivals: list[tuple[str, int]]) -> int:
    """How many report periods uav1's newest report was ahead of uav2's at most, over the arrivals."""
    newest: dict[str, int] = {}
    lead = 0
    for vehicle, stamp in arrivals:
        newest[vehicle] = max(stamp, newest.get(vehicle, stamp))
        if len(newest) == 2:
            lead = max(lead, (newest["uav1"] - newest["uav2"]) // PERIOD_NS)
    return lead


def test_a_vehicle_ahead_waits_for_the_slowest_and_never_leads_by_more_than_one_report(router: str) -> None:
    arrivals = _fly(router, lockstep=True)
    assert {v for v, _ in arrivals} == {"uav1", "uav2"}
    for vehicle in ("uav1", "uav2"):  # nothing skipped, nothing sent twice
        assert sorted(s for v, s in arrivals if v == vehicle) == [k * PERIOD_NS for k in range(8)]
    assert _lead_of_uav1(arrivals) <= 1


def test_without_lockstep_the_slowed_vehicle_falls_behind(router: str) -> None:
    """The test above has teeth: the same two runners without lockstep come apart."""
    assert _lead_of_uav1(_fly(router, lockstep=False)) >= 4


def test_a_restarted_process_joins_the_running_vehicles_not_the_wall_clock(router: str) -> None:
    """--start-at in the past with lockstep: the new process's target is moved to where the running vehicle
    is (here far behind the wall schedule, which is past the run's end), and it flies from the report after
    that vehicle's newest: a step nobody has reported for yet."""
    with _Observer(router) as observer:
        base, clock_start_ns = _options(router, True, 8.0), time.time_ns()
        slow = _Run(replace(base, only=("uav2",)), slow=True)  # starts its clock once up, after clock_start_ns
        observer.wait(lambda seen: len(seen) >= 2, "uav2 under way, behind its schedule (a tenth of the rate)")
        restarted = _Run(replace(base, only=("uav3",), start_at_ns=clock_start_ns))
        restarted.join()
        slow.join()
        seen = observer.wait(lambda seen: ("uav2", 7 * PERIOD_NS) in seen, "uav2's last report")
    first = next(i for i, (v, _) in enumerate(seen) if v == "uav3")
    newest_uav2 = max(s for v, s in seen[:first] if v == "uav2")
    stamps = sorted(s for v, s in seen if v == "uav3")
    # where uav2 was, not 30+ s on: the report after uav2's newest when the join began (uav2 may have sent
    # that one too before uav3's first arrived)
    assert newest_uav2 <= stamps[0] <= newest_uav2 + PERIOD_NS and stamps[0] > 0, (stamps, newest_uav2)
    assert stamps == list(range(stamps[0], 8 * PERIOD_NS, PERIOD_NS))  # then every report to the run's end


def test_a_runner_started_with_another_holds_its_clock_at_zero_until_that_one_is_up(router: str) -> None:
    """``start_with``: uav1, up first, publishes nothing before uav2's token is up (uav2 is built only once
    uav1's token is seen; unheld, uav1 would have flown its whole 0.2 s of wall time by then); then both fly
    every report from t = 0."""
    with _Observer(router) as observer:
        base = _options(router, True, 4.0)
        first = _Run(replace(base, only=("uav1",), start_with=("uav2",)))
        observer.wait_for_token("uav1")
        second = _Run(replace(base, only=("uav2",), start_with=("uav1",)))
        first.join()
        second.join()
        seen = observer.wait(lambda seen: len(seen) >= 8, "every report")
        assert observer.reports_before_token["uav2"] == 0, seen
    for vehicle in ("uav1", "uav2"):
        assert sorted(s for v, s in seen if v == vehicle) == [k * PERIOD_NS for k in range(4)]
