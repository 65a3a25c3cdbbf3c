"""The simulated vehicles' loop and scene without sockets: pacing, timers, determinism."""

from __future__ import annotations

import pytest

from gcs.config.world import build_world
from gcs.scenarios import load_scenario
from sim_vehicles.run_options import RunOptions
from sim_vehicles.runner import Runner, _Timer
from sim_vehicles.scene import Scene

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)


UNIX_NOW_NS = 1_800_000_000 * 1_000_000_000
"""The Unix time of a :class:`FakeClock` at zero."""


class FakeClock:
    """Wall time that passes only when the runner sleeps (monotonic seconds, and Unix ns from UNIX_NOW_NS)."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def unix_ns(self) -> int:
        return UNIX_NOW_NS + round(self.now * 1e9)

    def sleep(self, seconds: float) -> None:
        self.now += seconds


@pytest.mark.parametrize("rate", [0.5, 5.0, 40.0])
def test_rate_scales_wall_time_and_keeps_simulation_timers(rate: float) -> None:
    clock = FakeClock()
    runner = Runner(SCENARIO, WORLD, RunOptions(rate=rate, duration_s=10.0, seed=1), clock=clock, sleep=clock.sleep)
    summary = runner.run()
    assert summary.simulated_s == 10.0 and summary.steps == 200
    assert summary.wall_s == pytest.approx(10.0 / rate)
    assert summary.late_steps == 0
    assert dict(summary.reports) == {"uav1": 10, "uav2": 10, "uav3": 10}  # 1 Hz in simulation time: 0, 1, ..., 9 s
    assert dict(summary.nav_reports) == {"uav1": 50, "uav2": 50, "uav3": 50}  # 5 Hz


def test_timer_fires_on_its_simulation_time_grid_without_drift() -> None:
    timer = _Timer(3.0)
    fired = [k for k in range(1, 6001) if timer.due(k * 0.05)]  # 300 s in 0.05 s steps
    assert len(fired) == 901  # the n-th firing is due at n / 3 s, n = 0 .. 900
    assert all(0.0 <= k * 0.05 - n / 3.0 < 0.05 + 1e-9 for n, k in enumerate(fired[1:], start=1))


def _messages(seed: int) -> list:
    scene = Scene(SCENARIO, WORLD, seed=seed, epoch_ns=10**18)
    out = []
    for step in range(1, 201):
        scene.advance(0.05, {})
        if step % 20 == 0:
            out += [scene.sensor_report(v) for v in scene.vehicles]
        if step % 4 == 0:
            out += [scene.nav_report(v) for v in scene.vehicles]
    return out


def test_scene_is_deterministic_for_a_seed_and_varies_with_it() -> None:
    first, again, other = _messages(7), _messages(7), _messages(8)
    assert first == again
    assert first != other
    assert first[0].stamp_ns == 10**18 + 200_000_000  # the first nav report, after 4 steps of 0.05 s


def test_dead_reckoning_takes_over_in_a_gps_denied_zone() -> None:
    import msgspec

    from gcs.config.simulation import GpsDeniedZone

    zone = GpsDeniedZone(name="whole_city", polygon_enu_m=[(-1e4, -1e4), (1e4, -1e4), (1e4, 1e4), (-1e4, 1e4)])
    scenario = msgspec.structs.replace(SCENARIO, gps_denied=[zone])
    scene = Scene(scenario, WORLD, seed=2)
    for _ in range(200):
        scene.advance(0.05, {})
    nav = scene.nav_report("uav1")
    assert nav.gps is None and nav.ins is not None
    report = scene.sensor_report("uav1")
    truth = scene.vehicles["uav1"].state.position_enu_m
    error = sum((a - b) ** 2 for a, b in zip(report.vehicle_position_enu_m, truth)) ** 0.5
    assert 0.0 < error < 30.0  # dead reckoning drifts, but not far in 10 s
    assert report.vehicle_position_std_m > scenario.simulation.gps.horizontal_std_m


def test_a_scene_of_one_vehicle_draws_what_that_vehicle_draws_among_all() -> None:
    whole = Scene(SCENARIO, WORLD, seed=5)
    alone = Scene(SCENARIO, WORLD, seed=5, only=("uav2",))
    assert list(alone.vehicles) == ["uav2"]
    for _ in range(40):
        whole.advance(0.05, {})
        alone.advance(0.05, {})
    assert alone.sensor_report("uav2") == whole.sensor_report("uav2")
    assert alone.nav_report("uav2") == whole.nav_report("uav2")
    assert alone.truths() == whole.truths()
    with pytest.raises(ValueError, match="nobody"):
        Scene(SCENARIO, WORLD, seed=5, only=("nobody",))


def test_a_process_joining_a_clock_already_running_sees_the_same_target_and_ends_with_the_others() -> None:
    """--start-at in the past (a restarted vehicle process): the scene is advanced to the shared clock first."""
    clock = FakeClock()
    start_at_ns = UNIX_NOW_NS - 3_000_000_000  # the others started 3 s (6 simulated s at 2x) ago
    runner = Runner(SCENARIO, WORLD, RunOptions(rate=2.0, duration_s=10.0, seed=1, start_at_ns=start_at_ns,
                                                only=("uav2",)), clock=clock, sleep=clock.sleep,
                    unix_ns=clock.unix_ns)
    summary = runner.run()
    assert summary.simulated_s == pytest.approx(10.0)  # ends with the others, not 10 s after joining
    assert summary.reports["uav2"] == 4  # the reports of t = 6, 7, 8 and 9 s only: none before joining
    reference = Scene(SCENARIO, WORLD, seed=1)
    for _ in range(200):
        reference.advance(0.05, {})
    assert runner.scene.target.position == pytest.approx(reference.target.position)


def test_a_start_time_still_ahead_is_waited_for_and_nothing_is_skipped() -> None:
    clock = FakeClock()
    runner = Runner(SCENARIO, WORLD, RunOptions(rate=40.0, duration_s=3.0, seed=1, only=("uav1",),
                                                start_at_ns=UNIX_NOW_NS + 200_000_000), clock=clock,
                    sleep=clock.sleep, unix_ns=clock.unix_ns)
    summary = runner.run()
    assert summary.reports["uav1"] == 3 and summary.steps == 60  # the reports of t = 0, 1 and 2 s
