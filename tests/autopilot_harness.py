"""Fly one simulated autopilot personality without sockets: messages are packed and parsed as on the wire."""

from __future__ import annotations

import numpy as np

from gcs.adapters.mavlink_wire import GCS_SYSID, mavlink
from gcs.config.simulation import AirframeConfig
from gcs.core.geometry import LocalFrame
from sim_vehicles.personalities import make_autopilot
from sim_vehicles.truth.fixed_wing import Airframe, AirframeState
from sim_vehicles.truth.gps import GpsReading

DT = 0.05
SPEED = 25.0
ALTITUDE = 200.0
FRAME = LocalFrame(47.0, 8.0, 400.0)


class Flight:
    """One vehicle (sysid 1) under personality ``name``, at 25 m/s and 200 m, heading east, in GUIDED/OFFBOARD
    only when told; ``send`` hands it a GCS message and returns the parsed replies."""

    def __init__(self, name: str, max_turn_rate_rad_s: float = 0.5, wind=(0.0, 0.0), config=AirframeConfig()) -> None:
        self.gcs = mavlink.MAVLink(None, srcSystem=GCS_SYSID, srcComponent=190)
        self.vehicle_side = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self.ap = make_autopilot(name, 1, FRAME, config, SPEED, ALTITUDE, self.vehicle_side, 4.0)
        self.airframe = Airframe(config, max_turn_rate_rad_s, wind)
        self.wind = wind
        self.state = AirframeState(np.array([1000.0, 1000.0, ALTITUDE]), heading_rad=0.0, roll_rad=0.0,
                                   airspeed_mps=SPEED)
        self.t = 0.0
        self.ap.start(self.state)
        self._decoder = mavlink.MAVLink(None)

    def _wire(self, message, encoder):
        data = message.pack(encoder)
        parsed = self._decoder.parse_buffer(data)
        assert parsed and len(parsed) == 1
        return parsed[0]

    def send(self, message) -> list:
        """Deliver a GCS message now; the replies as a peer would read them."""
        replies = self.ap.handle(self._wire(message, self.gcs), self.t, self.state)
        return [self._wire(reply, self.vehicle_side) for reply in replies]

    def command(self, command: int, *params: float, frame: int | None = None) -> int:
        """COMMAND_LONG (frame None) or COMMAND_INT; the COMMAND_ACK result."""
        p = list(params) + [0.0] * (7 - len(params))
        if frame is None:
            message = self.gcs.command_long_encode(1, 1, command, 0, *p)
        else:
            message = self.gcs.command_int_encode(1, 1, frame, command, 0, 0, *p[:4], int(p[4]), int(p[5]), p[6])
        acks = [r for r in self.send(message) if r.get_type() == "COMMAND_ACK"]
        assert len(acks) == 1 and acks[0].command == command
        return acks[0].result

    def fly(self, seconds: float, every=None) -> list[AirframeState]:
        """Advance ``seconds``; ``every(flight)`` runs before each step (e.g. to stream setpoints)."""
        states = []
        for _ in range(round(seconds / DT)):
            if every is not None:
                every(self)
            self.ap.update(self.t, self.state, self.wind)
            self.state = self.airframe.step(self.state, self.ap.guidance, DT)
            self.t = round(self.t + DT, 9)
            states.append(self.state)
        return states

    def streamed(self, seconds: float) -> dict[str, int]:
        """How many of each streamed message the vehicle sends over the next ``seconds`` (flying on)."""
        counts: dict[str, int] = {}
        gps = GpsReading(position_enu_m=None, fix_type=0, satellites=0, horizontal_std_m=0.0, vertical_std_m=0.0)
        for _ in range(round(seconds / DT)):
            for message in self.ap.streams(self.t, self.state, gps, self.wind):
                counts[message.get_type()] = counts.get(message.get_type(), 0) + 1
            self.fly(DT)
        return counts
