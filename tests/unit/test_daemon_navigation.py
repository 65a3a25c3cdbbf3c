"""The daemon's per-vehicle navigation (gcs.engine.navigation) and the steps that wait for it (gcs.engine.steps).

Nav reports are made here: a vehicle flying a circle at 25 m/s, 5 reports a second, each
with the INS increments since the previous one and a GPS fix outside a denied interval.
"""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest

from gcs.core.geometry import LocalFrame
from gcs.core.tracker import TrackerConfig
from gcs.engine.fusion import step_detections
from gcs.engine.navigation import MAX_EXTRAPOLATION_S, FleetNavigator
from gcs.engine.steps import ReadyStep, StepAssembler
from gcs.scenarios import load_scenario
from gcs.engine.tracker_factory import tracker_config
from protocols.messages import GpsFix, InsIncrement, Measurement, NavReport, SensorReport

S = 1_000_000_000
EPOCH_NS = 1_000 * S
NAV_DT_S = 0.2
SCENARIO = load_scenario("wang2012_urban")
FRAME = LocalFrame(SCENARIO.origin.lat_deg, SCENARIO.origin.lon_deg, SCENARIO.origin.height_m)
SPEED, TURN = 25.0, 0.05  # m/s, rad/s


def _truth(t: float) -> tuple[float, float, float]:
    """x, y, heading of the circle at t seconds."""
    heading = 0.3 + TURN * t
    radius = SPEED / TURN
    return 1000.0 + radius * math.sin(heading), 1000.0 - radius * math.cos(heading), heading


def _navs(vehicle: str, seconds: float, rng: np.random.Generator, denied=(math.inf, math.inf)) -> list[NavReport]:
    """Nav reports every 0.2 s; no fix for ``denied[0] <= t < denied[1]`` (INS and heading only then)."""
    reports = []
    for k in range(round(seconds / NAV_DT_S) + 1):
        t = k * NAV_DT_S
        x, y, heading = _truth(t)
        gps = velocity = None
        if not denied[0] <= t < denied[1]:
            lat, lon, alt = FRAME.to_geodetic(np.array([x + rng.normal(0, 2.0), y + rng.normal(0, 2.0), 200.0]))
            gps = GpsFix(lat_deg=float(lat), lon_deg=float(lon), alt_m=float(alt), fix_type=3, h_acc_m=2.0,
                         v_acc_m=3.0)
            velocity = (SPEED * math.cos(heading), SPEED * math.sin(heading), 0.0)
        ins = None if k == 0 else InsIncrement(dt_s=NAV_DT_S, distance_m=SPEED * NAV_DT_S + rng.normal(0, 0.2),
                                               heading_change_rad=TURN * NAV_DT_S + rng.normal(0, 0.002))
        reports.append(NavReport(vehicle_id=vehicle, seq=k + 1, stamp_ns=EPOCH_NS + round(t * S), gps=gps, ins=ins,
                                 velocity_enu_mps=velocity, heading_rad=heading))
    return reports


def _navigator() -> FleetNavigator:
    return FleetNavigator.from_scenario(SCENARIO)


def _estimates(navigator: FleetNavigator, vehicles, steps: int) -> list:
    return [navigator.position_at(v, EPOCH_NS + k * S) for k in range(steps) for v in vehicles]


def _fed_by_step(navs: list[NavReport], steps: int, order) -> list:
    """Every step k: the reports stamped in (T_{k-1}, T_k] (plus, early, some of the next step's) in ``order``,
    then advance to T_k and read each vehicle's position there."""
    navigator, out = _navigator(), []
    pending = sorted(navs, key=lambda r: r.stamp_ns)
    for k in range(steps):
        stamp = EPOCH_NS + k * S
        due = [r for r in pending if r.stamp_ns <= stamp]
        early = [r for r in pending if stamp < r.stamp_ns <= stamp + S // 2]
        arriving = order(due + early[: len(early) // 2])
        for report in arriving:
            assert navigator.add(report)
        sent = {id(r) for r in arriving}
        pending = [r for r in pending if id(r) not in sent]
        navigator.advance_to(stamp)
        out += [navigator.position_at(v, stamp) for v in ("uav1", "uav2")]
    return out, navigator


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_shuffled_arrival_within_the_window_gives_the_same_estimates(seed) -> None:
    rng = np.random.default_rng(seed)
    navs = _navs("uav1", 30, rng, denied=(8.0, 20.0)) + _navs("uav2", 30, rng)
    in_order, navigator = _fed_by_step(navs, 30, order=lambda rs: sorted(rs, key=lambda r: r.stamp_ns))
    shuffled, _ = _fed_by_step(navs, 30, order=lambda rs: [rs[i] for i in rng.permutation(len(rs))])
    assert all(a is not None for a in in_order)
    for (xy_a, cov_a), (xy_b, cov_b) in zip(in_order, shuffled):
        assert np.array_equal(xy_a, xy_b) and np.array_equal(cov_a, cov_b)  # bit for bit
    assert navigator.counters["nav.applied"] == len([r for r in navs if r.stamp_ns <= EPOCH_NS + 29 * S])


def test_a_vehicles_estimate_does_not_depend_on_the_other_vehicles_updated_with_it() -> None:
    # each round of due reports is one batched update (gcs.core.navigation.fleet_ekf): a vehicle whose
    # companions' nav is missing (or late) must get the same numbers, bit for bit, as in a full round
    rng = np.random.default_rng(5)
    own = _navs("uav1", 20, rng, denied=(6.0, 12.0))
    others = _navs("uav2", 20, rng) + _navs("uav3", 20, rng, denied=(2.0, 6.0))
    alone, together = _navigator(), _navigator()
    for k in range(20):
        stamp = EPOCH_NS + k * S
        for report in own:
            if stamp - S < report.stamp_ns <= stamp or (k == 0 and report.stamp_ns <= stamp):
                alone.add(report)
                together.add(report)
        for report in others:
            if stamp - S < report.stamp_ns <= stamp or (k == 0 and report.stamp_ns <= stamp):
                together.add(report)
        alone.advance_to(stamp)
        together.advance_to(stamp)
        a, b = alone.position_at("uav1", stamp), together.position_at("uav1", stamp)
        assert a is not None and np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert together.counters["nav.applied"] > alone.counters["nav.applied"] > 90


def test_the_covariance_grows_without_gps_and_shrinks_when_the_fix_returns_and_tracks_the_truth() -> None:
    rng = np.random.default_rng(4)
    navigator = _navigator()
    for report in _navs("uav1", 40, rng, denied=(10.0, 30.0)):
        navigator.add(report)
    std, err = {}, {}
    for k in range(1, 41):
        navigator.advance_to(EPOCH_NS + k * S)
        xy, cov = navigator.position_at("uav1", EPOCH_NS + k * S)
        std[k], err[k] = math.sqrt(np.linalg.eigvalsh(cov[:2, :2]).max()), math.hypot(*(xy - _truth(k)[:2]))
        assert cov[2, 2] == (9.0 if navigator.has_fix("uav1") else 0.0)  # v_acc^2 with a fix (module docstring)
    assert all(std[k + 1] > std[k] for k in range(11, 29))  # dead reckoning: grows every step
    assert std[29] > 2.0 * std[9] and std[31] < 0.6 * std[29] and std[40] < 1.2 * std[9]
    assert max(err.values()) < 4.0 * max(std.values())  # no estimate wildly off its own covariance


def test_a_report_at_or_before_a_fused_step_is_late_counted_and_never_applied() -> None:
    navs = _navs("uav1", 3, np.random.default_rng(5))
    navigator = _navigator()
    for report in navs[:6]:  # up to t = 1.0 s
        navigator.add(report)
    navigator.advance_to(EPOCH_NS + S)
    before = navigator.position_at("uav1", EPOCH_NS + S)
    late = NavReport(vehicle_id="uav1", seq=99, stamp_ns=EPOCH_NS + S, gps=navs[6].gps, ins=navs[6].ins)
    assert not navigator.add(late) and not navigator.add(navs[2])
    assert navigator.counters["rejected.late_nav"] == 2
    navigator.advance_to(EPOCH_NS + S)
    after = navigator.position_at("uav1", EPOCH_NS + S)
    assert np.array_equal(before[0], after[0]) and np.array_equal(before[1], after[1])
    assert navigator.add(navs[6])  # the next one is still in time


def test_bad_reports_are_counted_and_the_estimate_stands() -> None:
    navs = _navs("uav1", 2, np.random.default_rng(6))
    navigator = _navigator()
    no_fix = NavReport(vehicle_id="uav1", seq=1, stamp_ns=EPOCH_NS - S, ins=navs[1].ins)
    navigator.add(no_fix)
    navigator.advance_to(EPOCH_NS - S)
    assert navigator.counters["nav.waiting_for_fix"] == 1 and navigator.position_at("uav1", EPOCH_NS - S) is None
    for report in navs[:5]:
        navigator.add(report)
    navigator.advance_to(EPOCH_NS + 4 * S // 5)
    good = navigator.position_at("uav1", EPOCH_NS + 4 * S // 5)
    far = GpsFix(lat_deg=0.0, lon_deg=0.0, alt_m=0.0, fix_type=3, h_acc_m=1.0, v_acc_m=1.0)  # 12 000 km away
    nan = NavReport(vehicle_id="uav1", seq=7, stamp_ns=EPOCH_NS + 9 * S // 10, gps=navs[5].gps, heading_rad=math.nan,
                    velocity_enu_mps=(math.nan, 0.0, 0.0))  # unvalidated: as a caller bypassing ingest could
    for report in (NavReport(vehicle_id="uav1", seq=6, stamp_ns=EPOCH_NS + 17 * S // 20, gps=far), nan,
                   NavReport(vehicle_id="intruder", seq=1, stamp_ns=EPOCH_NS + S, gps=far)):
        navigator.add(report)
    navigator.advance_to(EPOCH_NS + 9 * S // 10)
    assert navigator.counters["rejected.nav_update"] == 2 and navigator.counters["nav.unlisted"] == 1
    still = navigator.position_at("uav1", EPOCH_NS + 4 * S // 5)
    assert np.array_equal(good[0], still[0]) and np.array_equal(good[1], still[1])
    assert navigator.position_at("uav1", EPOCH_NS + round((MAX_EXTRAPOLATION_S + 1) * S)) is None  # nav stopped
    assert navigator.counters["nav.stale"] == 1


def _seen(vehicle: str, stamp_ns: int, xyz) -> SensorReport:
    return SensorReport(vehicle_id=vehicle, seq=1, stamp_ns=stamp_ns, vehicle_position_enu_m=xyz,
                        detections=(Measurement(range_m=300.0, range_std_m=10.0, azimuth_rad=0.1, azimuth_std_rad=0.05,
                                                elevation_rad=-0.7, elevation_std_rad=0.05),))


def test_detections_use_the_navigated_position_and_covariance_and_fall_back_to_the_report_without_nav() -> None:
    config: TrackerConfig = tracker_config(SCENARIO, None, "ga_k5")
    navigator = _navigator()
    for report in _navs("uav1", 2, np.random.default_rng(7)):
        navigator.add(report)
    stamp = EPOCH_NS + 2 * S
    navigator.advance_to(stamp)
    ready = ReadyStep(2, stamp, (_seen("uav1", stamp, (5.0, 6.0, 201.5)), _seen("uav2", stamp, (7.0, 8.0, 210.0))))
    one, two = step_detections(ready, ["uav1", "uav2", "uav3"], config, navigator)
    xy, cov = navigator.position_at("uav1", stamp)
    assert np.array_equal(one.vehicle_xyz, [xy[0], xy[1], 201.5]) and np.array_equal(one.vehicle_cov, cov)
    assert abs(xy[0] - _truth(2.0)[0]) < 10.0 and cov[2, 2] == 9.0 and cov[0, 0] > 0.0
    assert np.array_equal(two.vehicle_xyz, [7.0, 8.0, 210.0]) and two.vehicle_cov is None  # uav2 sent no nav
    plain = step_detections(ready, ["uav1", "uav2", "uav3"], config)  # --navigation reported
    assert np.array_equal(plain[0].vehicle_xyz, [5.0, 6.0, 201.5]) and plain[0].vehicle_cov is None


def test_without_navigation_a_detection_carries_the_reported_position_std_on_every_axis() -> None:
    config: TrackerConfig = tracker_config(SCENARIO, None, "ga_k5")
    stated = msgspec.structs.replace(_seen("uav1", S, (5.0, 6.0, 201.5)), vehicle_position_std_m=2.5)
    silent = _seen("uav2", S, (7.0, 8.0, 210.0))
    one, two = step_detections(ReadyStep(1, S, (stated, silent)), ["uav1", "uav2", "uav3"], config)
    assert one.vehicle_cov == 6.25 and np.array_equal(one.position_cov, 6.25 * np.eye(3))  # per-axis variance
    assert two.vehicle_cov is None  # no std given: taken as exact


def _report(vehicle: str, stamp_ns: int) -> SensorReport:
    return SensorReport(vehicle_id=vehicle, seq=1, stamp_ns=stamp_ns, vehicle_position_enu_m=(0.0, 0.0, 100.0))


def test_a_step_waits_for_the_nav_of_every_vehicle_that_sends_nav_and_times_out_without_it() -> None:
    both = {"uav1", "uav2"}
    steps = StepAssembler(step_ns=S, max_wait_s=0.5)
    for vehicle in both:
        steps.add(_report(vehicle, 0), 0.0)
    steps.add_nav("uav1", 0)
    assert [s.index for s in steps.ready(both, 0.5)] == [0]  # the first step always waits for its timeout
    steps.add(_report("uav1", S), 1.0)
    steps.add(_report("uav2", S), 1.0)
    steps.add_nav("uav1", S - S // 5)
    assert steps.ready(both, 1.1) == []  # uav1's nav for T_1 is not in yet (uav2 never sent nav: not waited for)
    steps.add_nav("uav1", S)
    assert [s.index for s in steps.ready(both, 1.1)] == [1]  # complete: no timeout
    steps.add(_report("uav1", 2 * S), 2.0)
    steps.add(_report("uav2", 2 * S), 2.0)
    steps.add_nav("uav1", 2 * S - S // 5)
    assert steps.ready(both, 2.49) == []
    assert [s.index for s in steps.ready(both, 2.5)] == [2]  # uav1's nav never came: released by timeout
    assert steps.counters["steps_released_by_timeout"] == 2
    steps.add(_report("uav2", 3 * S), 3.0)
    steps.add(_report("uav1", 3 * S), 3.0)
    steps.add(_report("uav1", 5 * S), 3.1)  # uav1 is two steps on: neither its report nor its nav is waited for
    assert [s.index for s in steps.ready(both, 3.1)] == [3]
    steps.add(_report("uav1", 4 * S), 4.0)
    steps.add(_report("uav2", 4 * S), 4.0)
    steps.add_nav("uav2", 3 * S)  # uav2's nav stopped a step before T_4 (as uav1's): nobody is waited for
    assert [s.index for s in steps.ready(both, 4.0)] == [4, 5]  # 4 complete; 5 (uav1's early report) timed out
    assert steps.counters["steps_released_by_timeout"] == 3


def test_replay_processing_with_delayed_nav_gives_the_tracks_of_the_undelayed_file(tmp_path) -> None:
    """Each vehicle's nav reports arrive up to 0.4 s late (in the order it sent them): same tracks, bit for bit."""
    from gcs.adapters.recording import Recorder, read_recording
    from sim_vehicles.recording import record_scene
    from gcs.config.world import build_world
    from gcs.recordings.replay import process

    scenario = load_scenario("wang2012_gps_denied")
    inputs, delayed = tmp_path / "inputs.mcap", tmp_path / "delayed.mcap"
    record_scene(scenario, build_world(scenario), inputs, duration_s=40, seed=2)
    rng, last = np.random.default_rng(8), {}
    rows = []
    for record in read_recording(inputs):
        time_ns = record.log_time_ns
        if "/nav" in record.key:  # FIFO per vehicle, as Zenoh delivers one publisher's messages
            time_ns = max(time_ns + int(rng.uniform(0.0, 0.4) * S), last.get(record.key, 0))
            last[record.key] = time_ns
        rows.append((time_ns, record.key, record.payload, record.encoding))
    with Recorder(delayed) as recorder:
        for time_ns, key, payload, encoding in sorted(rows, key=lambda row: row[0]):
            recorder.write(key, payload, encoding, time_ns)
    tracks, _, counters = process(inputs, scenario)
    again, _, delayed_counters = process(delayed, scenario)
    reported, _, _ = process(inputs, scenario, navigation="reported")
    assert len(tracks) >= 35 and counters["nav.applied"] > 0 and "rejected.late_nav" not in delayed_counters
    assert again == tracks
    assert [t.state for t in reported] != [t.state for t in tracks]  # the navigation is really used
    assert counters["nav.applied"] == delayed_counters["nav.applied"]

    # replay --process's score against the recorded truth: tracks moved 3 m east and 4 m north of it score 5 m
    import msgspec

    from gcs.recordings.replay import truth_error
    from protocols.codec import decode
    from protocols.messages import TargetTruth

    truth = {m.stamp_ns: m.position_enu_m for m in (decode(r.payload, r.encoding, TargetTruth)
                                                   for r in read_recording(inputs) if "/truth/" in r.key)}
    off = [msgspec.structs.replace(t, state=(truth[t.stamp_ns][0] + 3.0, truth[t.stamp_ns][1] + 4.0, *t.state[2:]))
           for t in tracks]
    rmse, scored = truth_error(inputs, off, S, SCENARIO.target.id)
    assert scored == len(tracks) and rmse == pytest.approx(5.0, abs=1e-9)
    assert truth_error(inputs, tracks, S, SCENARIO.target.id)[0] > 0.0
    assert truth_error(inputs, off, S, "another") == (None, 0)  # no truth of that target recorded


def test_against_the_simulators_truth_the_covariance_is_about_right_with_a_fix_and_not_far_off_without() -> None:
    """The simulated vehicles' nav reports (GPS with its wandering bias, INS with scale error and drift), loitering
    half in a GPS-denied half-plane: the mean normalised error squared (2 is consistent) with and without a fix."""
    import msgspec

    from gcs.config.simulation import GpsDeniedZone
    from gcs.config.world import build_world
    from sim_vehicles.scene import Scene

    scenario = msgspec.structs.replace(SCENARIO, gps_denied=[GpsDeniedZone(
        name="west", polygon_enu_m=[(0.0, 0.0), (1200.0, 0.0), (1200.0, 3000.0), (0.0, 3000.0)])])
    scene = Scene(scenario, build_world(scenario), seed=1, epoch_ns=EPOCH_NS)
    navigator = FleetNavigator.from_scenario(scenario)
    nees: dict[bool, list[float]] = {True: [], False: []}
    dt = scenario.simulation.physics_step_s
    for step in range(round(120.0 / dt)):
        if step % round(NAV_DT_S / dt) == 0:
            for vehicle in scene.vehicles:
                navigator.add(scene.nav_report(vehicle))
        if step % round(1.0 / dt) == 0 and step > 0:
            navigator.advance_to(scene.stamp_ns)
            for vehicle_id, vehicle in scene.vehicles.items():
                xy, cov = navigator.position_at(vehicle_id, scene.stamp_ns)
                error = xy - vehicle.state.position_enu_m[:2]
                nees[bool(navigator.has_fix(vehicle_id))].append(float(error @ np.linalg.solve(cov[:2, :2], error)))
        scene.advance(dt, {})
    assert len(nees[False]) >= 30 and len(nees[True]) >= 200
    assert 1.0 < np.mean(nees[True]) < 3.5  # without the GPS bias term about 8-11 (module docstring)
    assert np.mean(nees[False]) < 8.0  # the INS biases, allowed for as white noise: somewhat overconfident


def test_auto_navigation_runs_the_skf_only_where_the_scenario_declares_gps_denied_zones() -> None:
    from gcs.engine.navigation import navigator_for

    denied = load_scenario("wang2012_gps_denied")
    assert denied.gps_denied and not SCENARIO.gps_denied
    assert navigator_for("auto", denied) is not None and navigator_for("auto", SCENARIO) is None
    assert navigator_for("skf", SCENARIO) is not None and navigator_for("reported", denied) is None
    with pytest.raises(ValueError, match="unknown navigation"):
        navigator_for("gnss", SCENARIO)
