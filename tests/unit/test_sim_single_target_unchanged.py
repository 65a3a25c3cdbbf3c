"""Default single-target scenarios: the simulator's reports, random streams and replayed tracks are those of
the single-measurement wire (``SensorReport/1``).

``data/single_target_golden.json`` holds what the simulator and ``gcs replay --process`` produced before
reports carried a list of detections (seed 11 reports of three shipped scenarios; seed 4, 30 s of
wang2012_urban processed): every figure here is compared with those recorded values, not with this build.

The golden file was written on one machine. NumPy and OpenBLAS choose their kernels by CPU (SIMD width, FMA,
summation order), so another CPU gives the same computation with other last digits: its floats are compared
within :data:`RELATIVE_TOLERANCE` (see there), everything else (ids, stamps, detection flags, counts) exactly.
A v1 and a v2 recording processed in the same run must give the same tracks bit for bit.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import msgspec
import pytest

from gcs.adapters.recording import Recorder, read_recording
from sim_vehicles.recording import record_scene
from gcs.config.world import build_world
from gcs.recordings.replay import process
from gcs.scenarios import load_scenario
from protocols.codec import decode
from protocols.legacy import SensorReportV1
from protocols.messages import SensorReport
from sim_vehicles.scene import Scene

GOLDEN = json.loads((Path(__file__).parent / "data" / "single_target_golden.json").read_text())
V1_ENCODING = "application/json;gcs.SensorReport/1"

RELATIVE_TOLERANCE = 1e-9
"""How far a float may sit from its golden value, relative to the larger of the two.

Round-off: each operation is exact to half an ulp (1.1e-16 relative) on every CPU, but the kernels differ in
order and fusing, and the differences accumulate over the 240 physics steps of a scene or the 30 filter
steps of a replay. Re-running these computations here with every OpenBLAS core type (``OPENBLAS_CORETYPE``
Haswell, Zen, SkylakeX, Sandybridge, Nehalem, Prescott, Core2) and NumPy's SIMD levels down to X86_V2
(``NPY_DISABLE_CPU_FEATURES``) moved them by at most 4e-13 relative (an AMD EPYC's own kernels: 1.4e-13).
1e-9 leaves more than three orders of magnitude of margin; a change of the model or of a random stream moves
these figures by metres or milliradians, and a golden figure moved by 1e-7 of itself already fails.
"""
ABSOLUTE_TOLERANCE = 1e-9
"""Floor for figures near zero (an azimuth or velocity close to 0), in their own unit (m, rad, m/s, m^2):
round-off there is relative to the figures they are computed from (hundreds of metres, radians), not to
their own size, and 1e-9 m or rad is far below what any change of the model moves."""


def assert_matches_golden(value: object, golden: object, where: str = "") -> None:
    """``value`` is ``golden`` with floats within the tolerances above and everything else exactly equal.

    Detection flags, and so which fields are ``None``, are compared exactly: one could differ across CPUs only
    if a range or a line of sight fell within round-off (about 1e-10 m) of the sensor's range limit or of a
    building's edge, a chance of the order of 1e-12 for a scan over hundreds of metres. Had it happened, the
    figures that follow would differ by far more than round-off too: it is a difference to report, not noise.
    """
    if isinstance(golden, float) and isinstance(value, float):
        assert math.isclose(value, golden, rel_tol=RELATIVE_TOLERANCE, abs_tol=ABSOLUTE_TOLERANCE), \
            f"{where}: {value!r}, golden {golden!r}"
    elif isinstance(golden, list) and isinstance(value, list):
        assert len(value) == len(golden), f"{where}: {len(value)} entries, golden {len(golden)}"
        for i, (v, g) in enumerate(zip(value, golden)):
            assert_matches_golden(v, g, f"{where}[{i}]")
    else:
        assert type(value) is type(golden) and value == golden, f"{where}: {value!r}, golden {golden!r}"


def _as_v1_row(report: SensorReport) -> list:
    """The fields a version-1 report had, from a version-2 one of at most one detection."""
    assert len(report.detections) <= 1
    d = report.detections[0] if report.detections else None
    values = [None] * 6 if d is None else [d.range_m, d.azimuth_rad, d.elevation_rad,
                                           d.range_std_m, d.azimuth_std_rad, d.elevation_std_rad]
    return [report.vehicle_id, report.stamp_ns, report.detected, *values, list(report.vehicle_position_enu_m)]


@pytest.mark.parametrize("name", ["wang2012_urban", "zuo2021_aoa", "downtown_dense"])
def test_default_scenarios_report_what_they_reported_before(name: str) -> None:
    scenario = load_scenario(name)
    scene = Scene(scenario, build_world(scenario), seed=11, epoch_ns=0)
    rows = []
    for _ in range(12):
        for _ in range(20):
            scene.advance(0.05, {})
        rows += [_as_v1_row(scene.sensor_report(v)) for v in scene.vehicles]
    assert_matches_golden(rows, GOLDEN[name]["reports"], f"{name} reports")
    assert [t.target_id for t in scene.truths()] == [scenario.target.id]
    assert_matches_golden([float(v) for v in scene.target.position], GOLDEN[name]["truth"], f"{name} truth")


def _v1_copy(source: Path, target: Path) -> int:
    """The recording with every report rewritten as the version-1 payload of the same measurement; how many."""
    rewritten = 0
    with Recorder(target) as recorder:
        for r in read_recording(source):
            payload, encoding = r.payload, r.encoding
            if encoding.startswith("application/json;gcs.SensorReport/"):
                report = decode(payload, encoding, SensorReport)
                d = report.detections[0] if report.detections else None
                fields = {} if d is None else {k: getattr(d, k) for k in d.__struct_fields__}
                old = SensorReportV1(vehicle_id=report.vehicle_id, seq=report.seq, stamp_ns=report.stamp_ns,
                                     vehicle_position_enu_m=report.vehicle_position_enu_m,
                                     vehicle_position_std_m=report.vehicle_position_std_m,
                                     detected=d is not None, **fields)
                payload, encoding = msgspec.json.encode(old), V1_ENCODING
                rewritten += 1
            recorder.write(r.key, payload, encoding, r.log_time_ns)
    return rewritten


def test_recorded_v1_streams_replay_to_the_tracks_they_gave(tmp_path: Path) -> None:
    scenario = load_scenario("wang2012_urban")
    inputs, old = tmp_path / "in.mcap", tmp_path / "v1.mcap"
    record_scene(scenario, build_world(scenario), inputs, duration_s=30.0, seed=4)
    assert _v1_copy(inputs, old) == 90  # 3 vehicles, one report a second for 30 s
    assert {r.encoding for r in read_recording(old) if r.key.endswith("/report")} == {V1_ENCODING}
    golden = GOLDEN["replay"]
    replayed = []
    for path in (inputs, old):
        tracks, _, counters = process(path, scenario)
        assert len(tracks) == golden["count"]  # one estimate a step: 30 steps of 1 s, no float decides it
        last = tracks[-1]
        assert_matches_golden([last.stamp_ns, [float(v) for v in last.state], [float(v) for v in last.covariance]],
                              golden["last"], f"{path.name} last track")
        assert not any(name.startswith("rejected") for name in counters)
        replayed.append([(t.stamp_ns, list(t.state), list(t.covariance)) for t in tracks])
    assert replayed[0] == replayed[1]  # same run, same kernels: the v1 wire gives the v2 tracks bit for bit
