"""The daemon and three simulated vehicles as four processes on loopback, scored from the wire.

The test listens to the same Zenoh traffic as the daemon: the vehicles' reports
say at which steps the target was seen, the simulator's truth and the daemon's
tracks give the RMSE. It is held to what physics allows (:func:`tests.figures.track_error_window`):
above the target's own motion over a step, below the error of one raw detection.
"""

from __future__ import annotations

import json
import math
import queue
import subprocess

import numpy as np

from gcs.adapters.zenoh_session import ZenohSettings, listening_endpoints, open_session
from gcs.daemon.cli import query_status
from gcs.scenarios import load_scenario
from protocols.codec import decode
from protocols.keys import reports_selector, tracks_selector, truth_selector
from protocols.messages import SensorReport, TargetTruth, TrackEstimate
from tests.e2e.processes import script, stop
from tests.figures import track_error_window
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, Lines, daemon_up

DURATION_S = 120
RATE = 1.0
"""Real time, as vehicles fly. At 2x the GA's deadline is 0.3 s of wall time, and on a slowed machine, beside
three simulators, the plans were cut short: a CI run saw the target in 107 of 120 steps (2026-11-23)."""
SEED = 0
VEHICLES = ("uav1", "uav2", "uav3")


def test_daemon_with_three_vehicle_processes_tracks_the_target_better_than_one_detection(tmp_path) -> None:
    daemon = subprocess.Popen(
        [script("gcs"), "run", "--seed", str(SEED), "--mavlink", ANY_UDP, "--zenoh-listen", ANY_PORT_ENDPOINT,
         "--http", "none"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    daemon_log = Lines(daemon.stderr)
    inbox: queue.Queue = queue.Queue()
    vehicles: list[subprocess.Popen] = []
    try:
        endpoint, ports = daemon_up(daemon_log)  # where the system let it listen
        mavlink = ports["uav1"]
        # the observer is a router the vehicles are clients of: it forwards their traffic to the daemon and their
        # liveliness tokens to each other, so that the three start one clock once all are up (--start-with)
        with open_session(ZenohSettings(mode="router", listen=(ANY_PORT_ENDPOINT,), connect=(endpoint,))) as session:
            (observer,) = listening_endpoints(session)
            for selector in (reports_selector(), truth_selector(), tracks_selector()):
                session.declare_subscriber(selector, lambda s: inbox.put((s.payload.to_bytes(), str(s.encoding))))
            assert query_status(ZenohSettings(connect=(endpoint,)), "gcs", 60.0) is not None  # daemon up first
            for vehicle in VEHICLES:
                others = [arg for other in VEHICLES if other != vehicle for arg in ("--start-with", other)]
                vehicles.append(subprocess.Popen(
                    [script("sim-vehicles"), "run", "--only", vehicle, "--seed", str(SEED), "--rate", str(RATE),
                     "--duration", str(DURATION_S), "--epoch-ns", "0", "--mavlink", f"udpout:127.0.0.1:{mavlink}",
                     "--zenoh-mode", "client", "--zenoh-connect", observer, *others,
                     "--json", str(tmp_path / f"{vehicle}.json")],
                    stdout=subprocess.DEVNULL, stderr=open(tmp_path / f"{vehicle}.log", "w")))
            for process in vehicles:
                assert process.wait(timeout=DURATION_S / RATE * 4 + 70) == 0, (tmp_path / "uav1.log").read_text()
            status = query_status(ZenohSettings(connect=(endpoint,)), "gcs", 5.0)
        received = []
        while not inbox.empty():
            received.append(inbox.get())
    finally:
        for process in vehicles:
            stop(process)
        code = stop(daemon)
    assert code == 130, daemon_log.rest()[-3000:]  # stopped by Ctrl-C (SIGINT), cleanly

    seen: dict[int, bool] = {}
    truth: dict[int, tuple[float, float]] = {}
    errors = []
    tracks = []
    for payload, encoding in received:
        name = encoding.rsplit(".", 1)[-1].split("/")[0]
        if name == "SensorReport":
            report = decode(payload, encoding, SensorReport)
            seen[report.stamp_ns] = seen.get(report.stamp_ns, False) or report.detected
        elif name == "TargetTruth":
            message = decode(payload, encoding, TargetTruth)
            truth[message.stamp_ns] = message.position_enu_m
        else:
            tracks.append(decode(payload, encoding, TrackEstimate))
    for track in tracks:
        if track.stamp_ns in truth:
            x, y = truth[track.stamp_ns]
            errors.append(math.hypot(track.state[0] - x, track.state[1] - y))
    steps = len(seen)
    seen_any = sum(seen.values())
    rmse = float(np.sqrt(np.mean(np.square(errors))))

    floor, ceiling = track_error_window(load_scenario("wang2012_urban"))
    summary = {"steps": steps, "seen_any": seen_any, "rmse_m": rmse, "tracks": len(tracks),
               "rmse_floor_m": floor, "rmse_ceiling_m": ceiling}
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    assert steps == DURATION_S, summary
    # The target seen in 90% of the steps, and the fused track better than one raw detection (14.1 m here:
    # 10 m of range, 0.05 rad of elevation from 200 m) and no better than the target's own motion allows
    # (measured 2026-11-23 in real time, three runs: 113-120 of 120 steps, RMSE 8.2-10.0 m; at 2x, seven runs:
    # 115-120 steps, 8.4-10.5 m, and 107 steps once on a slowed machine).
    assert seen_any >= 0.9 * steps, summary
    assert len(errors) >= 0.9 * steps, summary
    assert floor <= rmse <= ceiling, summary
    assert status is not None and {v.link for v in status.vehicles} <= {"ok", "lost"}
    assert status.counters.get("accepted.report", 0) == 3 * DURATION_S
    rejected = {k: v for k, v in status.counters.items() if k.startswith("rejected.")}
    # the three processes start their clocks a little apart: a step may be released before a vehicle that
    # has just joined reports for it; nothing else may be rejected
    assert set(rejected) <= {"rejected.late"} and rejected.get("rejected.late", 0) <= 6, status.counters
    assert status.counters["decisions"] >= 0.9 * steps
