"""Simulated vehicles that start on the ground: disarmed and parked until armed in their take-off mode."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.adapters.mavlink_wire import GCS_SYSID, mavlink
from gcs.config.simulation import AirframeConfig
from gcs.core.geometry import LocalFrame
from sim_vehicles.personalities import make_autopilot
from sim_vehicles.px4 import PX4_MODES
from sim_vehicles.truth.fixed_wing import Airframe, AirframeState

DT = 0.05
FRAME = LocalFrame(47.0, 8.0, 400.0)
TAKEOFF = {"arduplane": (13, 0), "ideal": (13, 0), "px4": (4, 2)}
"""Each personality's take-off mode as DO_SET_MODE's param2 and param3."""


class Ground:
    """One vehicle on the ground at (100, 200), heading north, under a personality."""

    def __init__(self, name: str) -> None:
        self.gcs = mavlink.MAVLink(None, srcSystem=GCS_SYSID, srcComponent=190)
        self.ap = make_autopilot(name, 1, FRAME, AirframeConfig(), 25.0, 200.0, mavlink.MAVLink(None, srcSystem=1),
                                 on_ground=True)
        self.airframe = Airframe(AirframeConfig(), 0.2, (3.0, 0.0))  # a 3 m/s wind: it does not move a parked plane
        self.state = AirframeState(np.array([100.0, 200.0, 0.0]), heading_rad=np.pi / 2, roll_rad=0.0,
                                   airspeed_mps=0.0)
        self.ap.start(self.state)
        self.t = 0.0

    def command(self, command: int, *params: float) -> int:
        p = list(params) + [0.0] * (7 - len(params))
        message = self.gcs.command_long_encode(1, 1, command, 0, *p)
        parsed = mavlink.MAVLink(None).parse_buffer(message.pack(self.gcs))[0]
        (ack,) = [r for r in self.ap.handle(parsed, self.t, self.state) if r.get_type() == "COMMAND_ACK"]
        return ack.result

    def fly(self, seconds: float) -> None:
        for _ in range(round(seconds / DT)):
            self.ap.update(self.t, self.state, (3.0, 0.0))
            self.state = self.airframe.step(self.state, self.ap.guidance, DT)
            self.t += DT


@pytest.mark.parametrize("name", ["ideal", "arduplane", "px4"])
def test_a_parked_vehicle_stays_put_disarmed_until_armed_in_its_takeoff_mode(name: str) -> None:
    ground = Ground(name)
    assert not ground.ap.armed and not ground.ap.heartbeat().base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    ground.fly(10.0)
    assert ground.state.position_enu_m == pytest.approx([100.0, 200.0, 0.0])  # not even the wind moves it
    main, sub = TAKEOFF[name]
    assert ground.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, main, sub) == 0
    ground.fly(5.0)
    assert ground.state.position_enu_m == pytest.approx([100.0, 200.0, 0.0])  # disarmed: still parked
    assert ground.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_ACCEPTED
    assert ground.ap.armed
    ground.fly(5.0)
    assert ground.state.position_enu_m[1] > 250.0 and 0.0 < ground.state.position_enu_m[2] < 50.0  # north, climbing
    ground.fly(30.0)  # climbs at 5 m/s at most: 50 m within 15 s
    assert ground.state.position_enu_m[2] == pytest.approx(50.0, abs=1.0)
    assert ground.ap.guidance.kind == "loiter"
    if name == "px4":
        assert ground.ap.mode == PX4_MODES["AUTO_LOITER"]  # PX4 holds after its take-off
    assert ground.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0) != mavlink.MAV_RESULT_ACCEPTED  # in flight


def test_a_vehicle_on_the_ground_can_be_disarmed_and_stays_parked_in_other_modes() -> None:
    ground = Ground("arduplane")
    assert ground.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_ACCEPTED
    assert ground.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 12) == 0  # LOITER
    ground.fly(5.0)
    assert ground.state.position_enu_m == pytest.approx([100.0, 200.0, 0.0])
    assert ground.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mavlink.MAV_RESULT_ACCEPTED
    assert not ground.ap.armed
