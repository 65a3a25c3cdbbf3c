"""Every track on Foxglove's map: a recording of three tracks converted to MCAP, read back from ``/map/tracks``.

Each track must be a Point at its estimate carrying its id, seq and 2-sigma semi-axes,
with its 2-sigma ellipse as a closed Polygon and its predicted path as a LineString;
the expected values are the recording's own tracks of the seq the feature names.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from gcs.adapters.recording import HEARTBEAT_ENCODING, read_recording
from gcs.config.world import build_world
from gcs.core.geometry import LocalFrame
from gcs.adapters.live_map.picture import Picture
from gcs.recordings.replay_view import _feed, to_foxglove
from gcs.scenarios import load_scenario
from tests.integration.test_foxglove_out import _geojson
from protocols.codec import decode
from protocols.messages import TrackEstimate
from tests.integration.tracks_recording import SCENARIO_NAME, STEPS, tracks_recording

SCENARIO = load_scenario(SCENARIO_NAME)
FRAME = LocalFrame(SCENARIO.origin.lat_deg, SCENARIO.origin.lon_deg, SCENARIO.origin.height_m)


def _enu(lonlat: list[list[float]]) -> np.ndarray:
    """(k, 2) ENU metres of GeoJSON positions (longitude, latitude) on the ground."""
    return np.array([FRAME.to_enu(lat, lon, 0.0)[:2] for lon, lat in lonlat])


def test_every_track_is_a_point_with_its_id_ellipse_and_predicted_path(tmp_path: Path) -> None:
    recording, out = tmp_path / "tracks.mcap", tmp_path / "map.mcap"
    last = tracks_recording(recording)
    recorded = {(t.target_id, t.seq): t for t in (decode(r.payload, r.encoding) for r in read_recording(recording)
                                                  if r.key.startswith("gcs/track/")) if isinstance(t, TrackEstimate)}
    to_foxglove(recording, SCENARIO, build_world(SCENARIO), out)
    with open(out, "rb") as stream:
        messages = [m for _, channel, m in make_reader(stream).iter_messages() if channel.topic == "/map/tracks"]
    assert len(messages) > 1
    features = _geojson(messages[-1].data)["features"]
    by_kind: dict[str, dict[str, dict]] = {}
    for feature in features:
        by_kind.setdefault(feature["properties"]["kind"], {})[feature["properties"]["target_id"]] = feature
    assert sorted(by_kind) == ["ellipse", "prediction", "track"]
    assert len(features) == 3 * len(last)
    for kind, features_of_kind in by_kind.items():
        assert sorted(features_of_kind) == sorted(last) == ["t1", "t2", "t3"], kind

    for target_id in last:
        point = by_kind["track"][target_id]
        assert point["geometry"]["type"] == "Point" and point["properties"]["name"] == target_id
        estimate = recorded[target_id, point["properties"]["seq"]]
        assert estimate == last[target_id]  # the last snapshot holds the last step's tracks
        assert point["properties"]["contributing"] == list(estimate.contributing_vehicles)
        assert _enu([point["geometry"]["coordinates"]])[0] == pytest.approx(estimate.state[:2], abs=0.06)
        cov = np.asarray(estimate.covariance).reshape(4, 4)[:2, :2]
        minor, major = np.linalg.eigvalsh(cov)
        axes = (point["properties"]["rx_m"], point["properties"]["ry_m"])
        assert axes == pytest.approx((2 * math.sqrt(major), 2 * math.sqrt(minor)), abs=0.06)

        ellipse = by_kind["ellipse"][target_id]
        assert ellipse["geometry"]["type"] == "Polygon" and ellipse["properties"]["seq"] == estimate.seq
        (ring,) = ellipse["geometry"]["coordinates"]
        assert ring[0] == ring[-1]  # closed
        offsets = _enu(ring[:-1]) - np.asarray(estimate.state[:2])
        mahalanobis = np.sqrt(np.einsum("ki,ij,kj->k", offsets, np.linalg.inv(cov), offsets))
        assert mahalanobis == pytest.approx(2.0, abs=0.02)  # every vertex on the 2-sigma ellipse

        path = by_kind["prediction"][target_id]["geometry"]
        assert path["type"] == "LineString" and len(path["coordinates"]) == len(estimate.prediction) + 1
        expected = [estimate.state[:2]] + [p.position_enu_m for p in estimate.prediction]
        assert _enu(path["coordinates"]) == pytest.approx(np.array(expected), abs=0.06)


def test_the_recorded_heartbeats_are_replayed_but_not_taken_for_wire_messages(tmp_path: Path) -> None:
    recording = tmp_path / "tracks.mcap"
    tracks_recording(recording)
    heartbeats = sum(r.encoding == HEARTBEAT_ENCODING for r in read_recording(recording))
    picture, counts = Picture(SCENARIO, build_world(SCENARIO), mode="replay"), Counter()
    for record in read_recording(recording):
        _feed(picture, record, counts)
    assert heartbeats == 3 * STEPS and counts["alive"] >= heartbeats
    assert picture.counters.get("picture.rejected", 0) == 0, picture.counters
