"""The live map to Foxglove: its WebSocket server on 127.0.0.1, and recordings converted to MCAP on a map.

The messages are read back without Foxglove's own code: a few lines of WebSocket
client, and a protobuf field walker whose field numbers are learnt by encoding a
probe message with known values.
"""

from __future__ import annotations

import base64
import json
import os
import socket
import struct
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from gcs.engine.tracker_factory import horizon_steps, scenario_planner
from gcs.adapters.foxglove_out import FoxgloveMissing, FoxgloveOptions, FoxgloveOut, foxglove_options
from gcs.adapters.recording import read_recording
from gcs.config.world import build_world
from gcs.core.geometry import LocalFrame
from gcs.recordings.replay_view import to_foxglove
from gcs.scenarios import load_scenario
from protocols.codec import decode
from protocols.messages import TargetTruth
from tests.recordings import run_recording

SCENARIO = load_scenario("wang2012_urban")
FRAME = LocalFrame(SCENARIO.origin.lat_deg, SCENARIO.origin.lon_deg, SCENARIO.origin.height_m)
WORLD = {"bounds_m": [0.0, 0.0, 300.0, 300.0],
         "buildings": [{"footprint": [[0.0, 0.0], [20.0, 0.0], [20.0, 10.0]], "height_m": 30.0}],
         "roads": [{"line": [[0.0, 20.0], [150.0, 20.0]], "one_way": False}],
         "no_fly": [{"name": "zone", "polygon": [[100.0, 100.0], [200.0, 100.0], [200.0, 200.0]], "floor_m": 0.0,
                     "ceiling_m": 500.0}]}
NS = 1_000_000_000


def _fields(data: bytes) -> dict[int, list]:
    """Protobuf fields by number: varints as int, 64-bit as double, length-delimited as bytes."""
    out: dict[int, list] = {}
    at = 0

    def varint() -> int:
        nonlocal at
        value = shift = 0
        while True:
            byte = data[at]
            at += 1
            value |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                return value

    while at < len(data):
        key = varint()
        number, wire = key >> 3, key & 7
        if wire == 0:
            value = varint()
        elif wire == 1:
            (value,), at = struct.unpack_from("<d", data, at), at + 8
        elif wire == 2:
            length = varint()
            value, at = data[at:at + length], at + length
        elif wire == 5:
            (value,), at = struct.unpack_from("<f", data, at), at + 4
        else:
            raise AssertionError(f"wire type {wire}")
        out.setdefault(number, []).append(value)
    return out


def _coordinates(payload: bytes) -> tuple[float, float, float]:
    """Latitude, longitude and altitude of an encoded LocationFix (field numbers from a probe)."""
    import foxglove.messages

    probe = _fields(foxglove.messages.LocationFix(latitude=11.0, longitude=22.0, altitude=33.0).encode())
    number = {values[0]: n for n, values in probe.items() if values and isinstance(values[0], float)}
    fields = _fields(payload)
    return fields[number[11.0]][0], fields[number[22.0]][0], fields[number[33.0]][0]


def _geojson(payload: bytes) -> dict:
    (text,) = _fields(payload)[1]
    return json.loads(text)


def _snapshot(x: float, y: float) -> tuple[dict, dict]:
    tracks = {"vehicles": [{"id": "uav1", "x": x, "y": y, "z": 200.0, "heading_rad": 0.0, "stamp_ns": 5 * NS,
                            "plan": [[x, y], [x + 50.0, y]], "planner": "ga_k5"}],
              "tracks": [{"target_id": "target", "seq": 1, "stamp_ns": 5 * NS, "x": 10.0, "y": 20.0,
                          "cov_xy": [[100.0, 0.0], [0.0, 25.0]], "ellipse": {"rx": 20.0, "ry": 10.0, "angle_rad": 0.0},
                          "prediction": [{"x": 15.0, "y": 20.0}], "contributing": ["uav1"]}],
              "truth": [{"target_id": "target", "stamp_ns": 5 * NS, "x": 12.0, "y": 21.0}]}
    return tracks, {"mode": "live", "rmse_m": 2.0}


class _WebSocket:
    """Just enough of a WebSocket client for Foxglove's protocol."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=10)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                          f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                          "Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n".encode())
        self.buffer = b""
        self._need(lambda: b"\r\n\r\n" in self.buffer)
        head, self.buffer = self.buffer.split(b"\r\n\r\n", 1)
        assert head.startswith(b"HTTP/1.1 101"), head

    def _need(self, ready) -> None:
        while not ready():
            chunk = self.sock.recv(65536)
            assert chunk, "the server closed the connection"
            self.buffer += chunk

    def receive(self) -> tuple[int, bytes]:
        """(opcode, payload) of the next frame (the server's frames are not masked)."""
        self._need(lambda: len(self.buffer) >= 2)
        size, start = self.buffer[1] & 0x7F, 2
        if size >= 126:
            extra = 2 if size == 126 else 8
            self._need(lambda: len(self.buffer) >= 2 + extra)
            size, start = int.from_bytes(self.buffer[2:2 + extra], "big"), 2 + extra
        self._need(lambda: len(self.buffer) >= start + size)
        opcode, payload = self.buffer[0] & 0x0F, self.buffer[start:start + size]
        self.buffer = self.buffer[start + size:]
        return opcode, payload

    def send_text(self, text: str) -> None:
        data, mask = text.encode(), os.urandom(4)
        header = bytes([0x81, 0x80 | 126]) + len(data).to_bytes(2, "big") if len(data) >= 126 else \
            bytes([0x81, 0x80 | len(data)])
        self.sock.sendall(header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data)))

    def close(self) -> None:
        self.sock.close()


def test_the_live_server_advertises_the_map_channels_and_streams_location_fixes() -> None:
    out = FoxgloveOut(FRAME, WORLD, FoxgloveOptions(server=("127.0.0.1", 0)))
    client = None
    try:
        out.log(*_snapshot(100.0, 200.0), log_time_ns=5 * NS)
        port = int(out.url.rsplit(":", 1)[1])
        assert out.url.startswith("ws://127.0.0.1:")
        client = _WebSocket(port)
        assert json.loads(client.receive()[1])["op"] == "serverInfo"
        channels = {}
        while not {"/map/vehicles/uav1", "/map/world", "/gcs/status"} <= set(channels):
            message = json.loads(client.receive()[1])
            if message["op"] == "advertise":
                channels.update({c["topic"]: c for c in message["channels"]})
        assert channels["/map/vehicles/uav1"]["schemaName"] == "foxglove.LocationFix"
        assert channels["/map/target/estimate"]["schemaName"] == "foxglove.LocationFix"
        assert channels["/map/world"]["schemaName"] == channels["/map/plans"]["schemaName"] == "foxglove.GeoJSON"
        assert channels["/map/tracks"]["schemaName"] == "foxglove.GeoJSON"
        client.send_text(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 7, "channelId": channels["/map/vehicles/uav1"]["id"]}]}))
        client.sock.settimeout(0.2)
        texts = []
        for _ in range(50):  # log until the subscription is in place and a fix arrives
            out.log(*_snapshot(300.0, -400.0), log_time_ns=6 * NS)
            try:
                opcode, frame = client.receive()
            except TimeoutError:
                continue
            if opcode == 2 and frame[0] == 1 and struct.unpack_from("<I", frame, 1)[0] == 7:
                break
            texts.append(frame[:200])
        else:
            pytest.fail(f"no message on the subscription; the server said {texts}")
        assert struct.unpack_from("<Q", frame, 5)[0] == 6 * NS  # log time
        lat, lon, height = _coordinates(frame[13:])
        assert FRAME.to_enu(lat, lon, height) == pytest.approx([300.0, -400.0, 200.0], abs=1e-6)
    finally:
        if client is not None:
            client.close()
        out.close()
        out.close()  # idempotent


def test_a_recording_converts_to_an_mcap_that_opens_on_a_map(tmp_path: Path) -> None:
    world = build_world(SCENARIO)
    recording = run_recording(tmp_path, SCENARIO, world, duration_s=12.0, seed=3)
    out = tmp_path / "map.mcap"
    counts = to_foxglove(recording, SCENARIO, world, out)
    with open(out, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        by_topic: dict[str, list] = {}
        for schema, channel, message in reader.iter_messages():
            by_topic.setdefault(channel.topic, []).append((schema.name if schema else None, channel.message_encoding,
                                                            message))
    assert counts["foxglove_messages"] == sum(summary.statistics.channel_message_counts.values())
    for topic in ("/map/vehicles/uav1", "/map/vehicles/uav2", "/map/vehicles/uav3", "/map/target/estimate",
                  "/map/target/truth"):
        assert {schema for schema, _, _ in by_topic[topic]} == {"foxglove.LocationFix"}, topic
    for topic in ("/map/world", "/map/target/prediction", "/map/plans", "/map/tracks"):
        assert {schema for schema, _, _ in by_topic[topic]} == {"foxglove.GeoJSON"}, topic
    assert {encoding for _, encoding, _ in by_topic["/gcs/status"]} == {"json"}
    times = [m.log_time for _, _, m in by_topic["/map/target/truth"]]
    assert times == sorted(times) and times[-1] - times[0] >= 10 * NS  # the data's timeline, 0.2 s apart at most

    truths = [decode(r.payload, r.encoding) for r in read_recording(recording) if "/sim/truth/" in r.key]
    last = max(truths, key=lambda t: t.stamp_ns)
    assert isinstance(last, TargetTruth)
    lat, lon, height = _coordinates(by_topic["/map/target/truth"][-1][2].data)
    assert FRAME.to_enu(lat, lon, height)[:2] == pytest.approx(last.position_enu_m, abs=0.06)  # the map's 0.1 m

    world_map = _geojson(by_topic["/map/world"][0][2].data)
    buildings = [f for f in world_map["features"] if f["properties"]["kind"] == "building"]
    assert len(buildings) == len(world.buildings.footprints) == 400
    ring = buildings[0]["geometry"]["coordinates"][0]
    assert ring[0] == ring[-1] and len(ring) == len(world.buildings.footprints[0]) + 1  # closed
    corner = FRAME.to_enu(ring[0][1], ring[0][0], 0.0)[:2]
    assert corner == pytest.approx(world.buildings.footprints[0][0], abs=0.06)
    prediction = _geojson(by_topic["/map/target/prediction"][-1][2].data)["features"][0]["geometry"]
    assert prediction["type"] == "LineString" and len(prediction["coordinates"]) == horizon_steps(SCENARIO, scenario_planner(SCENARIO)) + 1


def test_without_the_sdk_the_error_says_which_extra_to_install(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "foxglove", None)
    with pytest.raises(FoxgloveMissing, match=r"uav-tracking-gcs\[foxglove\]"):
        FoxgloveOut(FRAME, WORLD, FoxgloveOptions(mcap=Path("never.mcap")))

    class Args:
        foxglove, foxglove_mcap = None, Path("x.mcap")

    with pytest.raises(FoxgloveMissing):
        foxglove_options(Args())
    Args.foxglove_mcap = None
    assert foxglove_options(Args()) is None  # not asked for: no SDK needed
