"""The live map's snapshots to Foxglove: its live WebSocket server and MCAP files that open on a map.

Optional (the ``foxglove`` extra: ``pip install 'uav-tracking-gcs[foxglove]'``,
the official ``foxglove-sdk``). Each snapshot of the
:class:`~gcs.adapters.live_map.picture.Picture` is logged, with a context of its own (no
global state), on these channels:

==============================  =====================  ==========================================
topic                           schema                 content
==============================  =====================  ==========================================
``/map/vehicles/<id>``          foxglove.LocationFix   position, heading (from north, clockwise)
``/map/tracks``                 foxglove.GeoJSON       every track: a Point (id, seq, ellipse axes), its
                                                       2-sigma ellipse (Polygon), its prediction (LineString)
``/map/target/estimate``        foxglove.LocationFix   the first track, its position covariance
``/map/target/truth``           foxglove.LocationFix   the first truth (simulated runs)
``/map/target/prediction``      foxglove.GeoJSON       the first track's k+1..k+n prediction, a LineString
``/map/plans``                  foxglove.GeoJSON       each vehicle's planned path
``/map/world``                  foxglove.GeoJSON       the extent's outline, roads (LineStrings), buildings and
                                                       no-fly zones (polygons), every 5 s
``/gcs/status``                 JSON                   the ``/api/status`` document
==============================  =====================  ==========================================

ENU metres become WGS84 with the scenario's :class:`~gcs.core.geometry.LocalFrame`
(altitude: height above the ellipsoid); a covariance stays in ENU, which is
LocationFix's convention. Message times are the data's stamps; ``log_time`` is
the caller's (receive time live, recording time in a conversion). The
``/map/target/*`` channels carry one target (a single-target scenario's);
``/map/tracks`` carries them all.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from gcs.core.geometry import LocalFrame

if TYPE_CHECKING:
    from foxglove.channels import GeoJsonChannel, LocationFixChannel

__all__ = ["FoxgloveOptions", "FoxgloveOut", "FoxgloveMissing", "WORLD_EVERY_NS", "add_foxglove_arguments",
           "foxglove_options"]

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
WORLD_EVERY_NS = 5 * NS_PER_S
Points = Sequence[Sequence[float]] | NDArray[np.float64]
"""ENU ground points (k, 2), metres."""
"""The static world is logged again this often, so that a viewer that connects late gets it."""
COLOURS = [(0.12, 0.53, 0.90), (0.26, 0.63, 0.28), (0.56, 0.14, 0.67), (0.96, 0.32, 0.12), (0.0, 0.67, 0.76)]
ELLIPSE_POINTS = 36
"""Vertices of a track's 2-sigma ellipse polygon on ``/map/tracks``."""
TRACK_STYLE = {"color": "#d81b60", "opacity": 0.35}
PREDICTION_STYLE = {"color": "#fb8c00", "opacity": 0.9}
ROAD_STYLE = {"color": "#a08a5a", "weight": 3, "opacity": 0.8}
"""The roads on ``/map/world``: the live map's road colour, darker, to stand out on the map tiles' own roads."""
EXTENT_STYLE = {"color": "#757575", "weight": 1, "opacity": 0.8, "fill": False}
"""The world's extent (``bounds_m``) on ``/map/world``: an outline, the frame the live map's "whole city" shows."""


class FoxgloveMissing(RuntimeError):
    """The ``foxglove-sdk`` package is not installed."""


@dataclass(frozen=True)
class FoxgloveOptions:
    """Where the snapshots go: a Foxglove WebSocket server (host, port) and/or an MCAP file."""

    server: tuple[str, int] | None = None
    mcap: Path | None = None


def add_foxglove_arguments(parser: argparse.ArgumentParser) -> None:
    """``--foxglove ADDRESS`` and ``--foxglove-mcap FILE`` (the foxglove extra)."""
    parser.add_argument("--foxglove", type=_address, metavar="ADDRESS",
                        help="also serve the map to Foxglove's WebSocket client at ws://ADDRESS (e.g. 127.0.0.1:8766; "
                             "port 0 picks a free port; needs the foxglove extra)")
    parser.add_argument("--foxglove-mcap", type=Path, metavar="FILE.mcap",
                        help="also write the map to an MCAP file that opens on Foxglove's Map panel (LocationFix, "
                             "GeoJSON; needs the foxglove extra)")


def _address(text: str) -> tuple[str, int]:
    from gcs.adapters.web.server import parse_http_address

    try:
        address = parse_http_address(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error).replace("--http", "--foxglove")) from None
    if address is None:
        raise argparse.ArgumentTypeError("--foxglove wants HOST:PORT")
    return address


def foxglove_options(args: argparse.Namespace) -> FoxgloveOptions | None:
    """The options the arguments ask for (None: no Foxglove output); FoxgloveMissing without the SDK."""
    server, mcap = getattr(args, "foxglove", None), getattr(args, "foxglove_mcap", None)
    if server is None and mcap is None:
        return None
    _sdk()
    return FoxgloveOptions(server=server, mcap=mcap)


def _sdk():
    try:
        import foxglove
        import foxglove.messages
    except ImportError as error:
        raise FoxgloveMissing("Foxglove output needs the foxglove extra: pip install 'uav-tracking-gcs[foxglove]' "
                              f"(foxglove-sdk): {error}") from None
    return foxglove


class FoxgloveOut:
    """See the module docstring. Raises :class:`FoxgloveMissing`, or OSError/RuntimeError when the
    server cannot bind or the file cannot be written."""

    def __init__(self, frame: LocalFrame, world: dict, options: FoxgloveOptions) -> None:
        foxglove = _sdk()
        self._fg, self._m = foxglove, foxglove.messages
        self.frame, self.world = frame, world
        self.context = foxglove.Context()
        self.server = self.writer = None
        self.url: str | None = None
        try:
            if options.mcap is not None:
                self.writer = foxglove.open_mcap(options.mcap, allow_overwrite=True, context=self.context)
            if options.server is not None:
                host, port = options.server
                self.server = foxglove.start_server(name="gcs", host=host, port=port, context=self.context)
                self.url = f"ws://{host}:{self.server.port}"
        except BaseException:
            self.close()
            raise
        from foxglove.channels import GeoJsonChannel, LocationFixChannel

        self._location_fix, self._geojson = LocationFixChannel, GeoJsonChannel
        self._fixes: dict[str, LocationFixChannel] = {}
        self._maps: dict[str, GeoJsonChannel] = {}
        self._status = foxglove.Channel("/gcs/status", message_encoding="json", context=self.context)
        self._world_geojson = json.dumps(self._world_features())
        self._world_logged_ns: int | None = None
        self.messages = 0

    # ------------------------------------------------------------ conversion

    def _geodetic(self, xy: Points) -> NDArray[np.float64]:
        """(k, 2) ENU metres on the ground -> (k, 3) latitude, longitude, height."""
        enu = np.column_stack([np.asarray(xy, dtype=np.float64).reshape(-1, 2), np.zeros(len(xy))])
        return np.column_stack(self.frame.to_geodetic(enu))

    def _lonlat(self, xy: Points) -> list[list[float]]:
        return [[round(float(lon), 8), round(float(lat), 8)] for lat, lon, _ in self._geodetic(xy)]

    def _world_features(self) -> dict:
        """The ``/map/world`` collection: the extent's outline, the roads (LineStrings, a one-way road's in its driving
        sense), the buildings and the no-fly zones."""
        west, south, east, north = self.world["bounds_m"]
        corners = [[west, south], [east, south], [east, north], [west, north]]
        features = [{"type": "Feature", "properties": {"kind": "extent", "style": EXTENT_STYLE},
                     "geometry": {"type": "Polygon", "coordinates": [self._ring(corners)]}}]
        features += [{"type": "Feature",
                      "properties": {"kind": "road", "one_way": road["one_way"], "style": ROAD_STYLE},
                      "geometry": {"type": "LineString", "coordinates": self._lonlat(road["line"])}}
                     for road in self.world["roads"]]
        features += [{"type": "Feature", "properties": {"kind": "building", "height_m": b["height_m"],
                                                        "style": {"color": "#8d8a82", "opacity": 0.6}},
                      "geometry": {"type": "Polygon", "coordinates": [self._ring(b["footprint"])]}}
                     for b in self.world["buildings"]]
        features += [{"type": "Feature", "properties": {"kind": "no_fly", "name": z["name"], "floor_m": z["floor_m"],
                                                        "ceiling_m": z["ceiling_m"],
                                                        "style": {"color": "#e53935", "opacity": 0.3}},
                      "geometry": {"type": "Polygon", "coordinates": [self._ring(z["polygon"])]}}
                     for z in self.world["no_fly"]]
        return {"type": "FeatureCollection", "features": features}

    def _ring(self, polygon: Points) -> list[list[float]]:
        ring = self._lonlat(polygon)
        return ring + ring[:1]  # GeoJSON rings are closed

    def _ellipse_ring(self, x: float, y: float, e: dict) -> list[list[float]]:
        """The closed lon/lat ring of an ellipse (``rx`` along ``angle_rad`` from east, ``ry`` across it, m)."""
        phi = np.linspace(0.0, 2.0 * math.pi, ELLIPSE_POINTS, endpoint=False)
        c, s = math.cos(e["angle_rad"]), math.sin(e["angle_rad"])
        u, v = e["rx"] * np.cos(phi), e["ry"] * np.sin(phi)
        return self._ring(np.column_stack([x + c * u - s * v, y + s * u + c * v]))

    def track_features(self, tracks: list[dict]) -> list[dict]:
        """The ``/map/tracks`` features of the ``/api/tracks`` document's tracks: for each, a Point at the
        estimate (``target_id``, ``seq``, ``stamp_ns``, the 2-sigma semi-axes ``rx_m``, ``ry_m`` and
        ``angle_rad``, ``contributing``), the ellipse as a Polygon, and the estimate's path through its
        k+1..k+n prediction as a LineString (when it has one)."""
        features = []
        for t in tracks:
            e = t["ellipse"]
            ident = {"target_id": t["target_id"], "seq": t["seq"]}
            features.append({"type": "Feature", "properties": {
                "kind": "track", **ident, "name": t["target_id"], "stamp_ns": t["stamp_ns"], "rx_m": e["rx"],
                "ry_m": e["ry"], "angle_rad": e["angle_rad"], "contributing": list(t["contributing"]),
                "style": TRACK_STYLE}, "geometry": {"type": "Point", "coordinates": self._lonlat([[t["x"], t["y"]]])[0]}})
            features.append({"type": "Feature", "properties": {"kind": "ellipse", **ident, "style": TRACK_STYLE},
                             "geometry": {"type": "Polygon", "coordinates": [self._ellipse_ring(t["x"], t["y"], e)]}})
            if t["prediction"]:
                points = [[t["x"], t["y"]]] + [[p["x"], p["y"]] for p in t["prediction"]]
                features.append({"type": "Feature", "properties": {"kind": "prediction", **ident,
                                                                   "style": PREDICTION_STYLE},
                                 "geometry": {"type": "LineString", "coordinates": self._lonlat(points)}})
        return features

    def _timestamp(self, stamp_ns: int):
        return self._m.Timestamp(sec=stamp_ns // NS_PER_S, nsec=stamp_ns % NS_PER_S)

    def location_fix(self, stamp_ns: int, x: float, y: float, z: float = 0.0, heading_rad: float | None = None,
                     cov_xy: list | None = None, colour: tuple[float, float, float] | None = None):
        """The LocationFix of an ENU point (heading in ENU, from east counter-clockwise; cov (2, 2) m^2)."""
        lat, lon, height = self.frame.to_geodetic([x, y, z])
        fields = {"timestamp": self._timestamp(stamp_ns), "frame_id": "enu", "latitude": float(lat),
                  "longitude": float(lon), "altitude": float(height)}
        if heading_rad is not None:
            fields["heading"] = (math.pi / 2 - heading_rad) % (2 * math.pi)  # ENU from east CCW -> from north CW
        if cov_xy is not None:
            (a, b), (c, d) = cov_xy
            fields["position_covariance"] = [a, b, 0.0, c, d, 0.0, 0.0, 0.0, 0.0]
            fields["position_covariance_type"] = self._m.LocationFixPositionCovarianceType.Known
        if colour is not None:
            fields["color"] = self._m.Color(r=colour[0], g=colour[1], b=colour[2], a=1.0)
        return self._m.LocationFix(**fields)

    # --------------------------------------------------------------- logging

    def _fix(self, topic: str, message, log_time_ns: int) -> None:
        channel = self._fixes.get(topic)
        if channel is None:
            channel = self._fixes[topic] = self._location_fix(topic, context=self.context)
        channel.log(message, log_time=log_time_ns)
        self.messages += 1

    def _map(self, topic: str, features: list[dict], log_time_ns: int) -> None:
        channel = self._maps.get(topic)
        if channel is None:
            channel = self._maps[topic] = self._geojson(topic, context=self.context)
        geojson = json.dumps({"type": "FeatureCollection", "features": features})
        channel.log(self._m.GeoJson(geojson=geojson), log_time=log_time_ns)
        self.messages += 1

    def log(self, tracks: dict, status: dict, log_time_ns: int) -> None:
        """One snapshot of the picture (its ``/api/tracks`` and ``/api/status`` documents)."""
        if self._world_logged_ns is None or log_time_ns - self._world_logged_ns >= WORLD_EVERY_NS:
            channel = self._maps.get("/map/world") or self._geojson("/map/world", context=self.context)
            self._maps["/map/world"] = channel
            channel.log(self._m.GeoJson(geojson=self._world_geojson), log_time=log_time_ns)
            self._world_logged_ns = log_time_ns
            self.messages += 1
        plans = []
        for index, v in enumerate(tracks["vehicles"]):
            if v["x"] is None:
                continue
            self._fix(f"/map/vehicles/{v['id']}", self.location_fix(
                v["stamp_ns"], v["x"], v["y"], v["z"] or 0.0, v["heading_rad"], colour=COLOURS[index % len(COLOURS)]),
                log_time_ns)
            if v["plan"]:
                plans.append({"type": "Feature", "properties": {"vehicle": v["id"], "planner": v["planner"]},
                              "geometry": {"type": "LineString", "coordinates": self._lonlat(v["plan"])}})
        self._map("/map/plans", plans, log_time_ns)
        self._map("/map/tracks", self.track_features(tracks["tracks"]), log_time_ns)
        for track in tracks["tracks"][:1]:
            self._fix("/map/target/estimate", self.location_fix(track["stamp_ns"], track["x"], track["y"],
                                                                cov_xy=track["cov_xy"], colour=(0.85, 0.11, 0.38)),
                      log_time_ns)
            points = [[track["x"], track["y"]]] + [[p["x"], p["y"]] for p in track["prediction"]]
            self._map("/map/target/prediction", [{"type": "Feature", "properties": {"seq": track["seq"]},
                                                  "geometry": {"type": "LineString",
                                                               "coordinates": self._lonlat(points)}}], log_time_ns)
        for truth in tracks["truth"][:1]:
            self._fix("/map/target/truth", self.location_fix(truth["stamp_ns"], truth["x"], truth["y"],
                                                             colour=(0.0, 0.0, 0.0)), log_time_ns)
        self._status.log(status, log_time=log_time_ns)
        self.messages += 1

    def close(self) -> None:
        """Stop the server and finish the file (idempotent)."""
        if self.server is not None:
            self.server.stop()
            self.server = None
        if self.writer is not None:
            self.writer.close()
            self.writer = None
