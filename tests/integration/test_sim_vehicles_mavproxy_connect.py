"""MAVProxy connects to the simulated vehicles as to a real autopilot: healthy, and its parameters at once.

MAVProxy (PyPI 1.8.75) with its own modules for missions, fences, FTP and parameters, on
127.0.0.1, against the default scenario's three vehicles at 10x. At connection it asks for
the mission, fence and rally points (MISSION_REQUEST_LIST), and for the parameters by MAVLink
FTP first (``@PARAM/param.pck``), falling back to PARAM_REQUEST_LIST when FTP fails; its fence
module announces "fence breach" when SYS_STATUS's geofence health bit is clear.
"""

from __future__ import annotations

import re

import pytest

from gcs.adapters.mavlink_wire import mavlink
from tests.integration.mavproxy_harness import MavProxy
from tests.integration.sim_harness import options, running_vehicles

CONNECT_MODULES = ("wp", "rally", "fence", "ftp", "param", "mode", "arm", "cmdlong")
"""MAVProxy's default modules that talk to the vehicle when it connects, and those a test drives."""
WAIT_S = 20.0
"""Wall time for MAVProxy to connect and fetch the parameters."""


@pytest.fixture
def connecting(tmp_path):
    with MavProxy(workdir=tmp_path / "mavproxy", modules=CONNECT_MODULES) as proxy:
        with running_vehicles(options(proxy.master_port)) as runner:
            yield proxy, runner


def test_mavproxy_fetches_the_parameters_without_an_ftp_time_out_and_sees_no_fence_breach(connecting) -> None:
    proxy, runner = connecting
    proxy.wait_for_vehicle(1, WAIT_S)
    received = proxy.wait_for(r"Received (\d+) parameters", WAIT_S)
    transcript = proxy.transcript
    # over PARAM_REQUEST_LIST (not FTP), after FTP was refused at once rather than timed out
    assert "(ftp)" not in received.group(0) and int(received.group(1)) == len(runner.autopilots["uav1"].params)
    assert "FTP: request timed out" not in transcript
    ftp_requests = runner.autopilots["uav1"].counters["FILE_TRANSFER_PROTOCOL"]
    assert 1 <= ftp_requests <= 2, ftp_requests  # the open (and its session's end), each answered: no retries
    # every sensor the vehicle reports is healthy, the geofence bit included: no "fence breach"
    status = proxy.message("SYS_STATUS", WAIT_S)
    enabled, health = int(status["onboard_control_sensors_enabled"]), int(status["onboard_control_sensors_health"])
    assert health & enabled == enabled and health & mavlink.MAV_SYS_STATUS_GEOFENCE
    assert not re.search(r"fence breach|RC fail", proxy.transcript), proxy.transcript[-2000:]
