"""`sim-vehicles payload` as a process: it reads a vehicle's telemetry, counts the bad, stops on SIGINT with a
summary line per vehicle."""

from __future__ import annotations

import re
import subprocess
import time
from contextlib import ExitStack

from gcs.adapters.mavlink_wire import open_connection
from gcs.core.geometry import LocalFrame
from gcs.scenarios import load_scenario
from sim_vehicles.telemetry_messages import e7
from tests.e2e.processes import script, stop
from tests.loopback import LOCALHOST, Lines, silent_port

SCENARIO = load_scenario("wang2012_urban")


def test_bridge_reads_telemetry_counts_bad_and_prints_its_summary_on_sigint() -> None:
    frame = LocalFrame(SCENARIO.origin.lat_deg, SCENARIO.origin.lon_deg, SCENARIO.origin.height_m)
    with ExitStack() as stack:
        zenoh_port = stack.enter_context(silent_port())  # a peer that connects nowhere, and retries
        process = subprocess.Popen(
            [script("sim-vehicles"), "payload", "--vehicle", f"uav2=udpin:{LOCALHOST}:0", "--zenoh-connect",
             f"tcp/{LOCALHOST}:{zenoh_port}"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        stack.callback(lambda: stop(process))
        errors = Lines(process.stderr)
        port = int(errors.wait_for(r"uav2 \(sysid 2\) <- udpin:127\.0\.0\.1:0 \(listening on 127\.0\.0\.1:(\d+)\)",
                                   60).group(1))
        vehicle = open_connection(f"udpout:{LOCALHOST}:{port}", source_system=2)
        stack.callback(vehicle.close)
        lat, lon, _ = frame.to_geodetic([1800.0, 1200.0, 210.0])
        sent = 0
        for k in range(30):  # 3 s of telemetry at 10 Hz, one of them off the globe
            vehicle.mav.global_position_int_send(k * 100, e7(lat) if k != 10 else 95 * 10**7, e7(lon),
                                                 round((frame.height_m + 210.0) * 1000), 210_000, 2500, 0, 0, 0)
            vehicle.mav.gps_raw_int_send(k * 100_000, 3, e7(lat), e7(lon), 0, 121, 200, 2500, 0, 10, 0, 1500,
                                         2500, 0, 0)
            sent += 2
            time.sleep(0.1)
        errors.wait_for(r"uav2: bad telemetry #1 ignored \(GLOBAL_POSITION_INT\): position lat 95", 10)
        code = stop(process)
        out = process.stdout.read()
    assert code == 130, errors.rest()  # stopped by Ctrl-C, with its summary
    summary = re.search(r"uav2: (\d+) MAVLink messages read, (\d+) nav reports, (\d+) sensor reports \(\d+ "
                        r"detections\), (\d+) bad telemetry, 0 positions without a GPS fix, liveliness withdrawn 0 "
                        r"times", out)
    assert summary is not None, out
    read, navs, reports, bad = (int(g) for g in summary.groups())
    assert read == sent and bad == 1  # every datagram on loopback, one of them bad
    assert navs >= 10 and reports >= 2  # 5 Hz and 1 Hz over at least 2.9 s of fresh telemetry
