"""``gcs-bench livemap``: what the live map costs the daemon's loop.

The daemon hands its :class:`~gcs.adapters.live_map.picture.Picture` every message it
receives or publishes, and five times a second builds a snapshot, encodes it and
gives it to the server. Both run on the daemon's loop thread, so both are
measured here, without a network, for teams of several sizes: each vehicle
sends a nav report with a GPS fix at 5 Hz and a sensor report at 1 Hz, and gets
a plan each 1 s step; the target gets a track and a truth each step. The first
``warm_up_s`` simulated seconds fill the trails (600 points, the worst case);
over the next ``measure_s`` seconds every 0.2 s of messages is observed and then
a snapshot taken, as the daemon does.

Reported per team size: the median microseconds to observe one message, beside
its peer measured on the same messages in the same run, the codec's decoding
(what the daemon's ingest already pays for every message it receives); the
median and 99th-percentile milliseconds of a snapshot (build and encode); its
size; and the share of one core the map takes at real time (observing every
message and five snapshots a second).
"""

from __future__ import annotations

import json
import math
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from benchmarks.plots import pyplot, save, write_markdown
from benchmarks.urban import with_vehicles
from gcs.config import Scenario
from gcs.core.geometry import LocalFrame
from gcs.core.world import World
from gcs.adapters.live_map.picture import Picture
from gcs.adapters.live_map.picture_geometry import encode_json
from protocols.codec import decode, encode
from protocols.messages import (GpsFix, Message, NavReport, PlanCommand, PredictedPoint, SensorReport, TargetTruth,
                                TrackEstimate)

__all__ = ["messages", "run_benchmark", "format_report", "write_plots", "SNAPSHOT_HZ"]

NS_PER_S = 1_000_000_000
SNAPSHOT_HZ = 5.0
NAV_HZ = 5


def messages(scenario: Scenario, seconds: int) -> list[list[Message]]:
    """The messages of each 0.2 s of a run, in order: vehicles circling 300 m about their start points."""
    frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
    vehicles = scenario.vehicles
    start = np.array([v.start_enu_m for v in vehicles])
    t0 = NS_PER_S
    cov = tuple(float(x) for x in np.diag([25.0, 25.0, 4.0, 4.0]).ravel())
    chunks: list[list[Message]] = []
    for tick in range(seconds * NAV_HZ):
        t = tick / NAV_HZ
        stamp = t0 + tick * NS_PER_S // NAV_HZ
        angle = 25.0 / 300.0 * t + np.arange(len(vehicles))
        xy = start + 300.0 * np.column_stack([np.cos(angle), np.sin(angle)])
        lat, lon, height = frame.to_geodetic(np.column_stack([xy, np.full(len(vehicles), 200.0)]))
        chunk: list[Message] = [
            NavReport(vehicle_id=v.id, seq=tick + 1, stamp_ns=stamp, heading_rad=float(math.remainder(a + 1.57, 2 * math.pi)),
                      gps=GpsFix(lat_deg=float(la), lon_deg=float(lo), alt_m=float(h), fix_type=3, h_acc_m=2.0,
                                 v_acc_m=3.0))
            for v, a, la, lo, h in zip(vehicles, angle, lat, lon, height)]
        if tick % NAV_HZ == 0:
            step = tick // NAV_HZ + 1
            target = (1500.0 + 5.0 * t, 1500.0)
            chunk += [SensorReport(vehicle_id=v.id, seq=step, stamp_ns=stamp,
                                   vehicle_position_enu_m=(float(p[0]), float(p[1]), 200.0)) for v, p in zip(vehicles, xy)]
            chunk.append(TargetTruth(target_id="target", seq=step, stamp_ns=stamp, position_enu_m=target,
                                     velocity_enu_mps=(5.0, 0.0)))
            chunk.append(TrackEstimate(
                target_id="target", seq=step, stamp_ns=stamp, model="cv2d", state=(target[0] + 3.0, target[1], 5.0, 0.0),
                covariance=cov, contributing_vehicles=tuple(v.id for v in vehicles[:3]),
                prediction=tuple(PredictedPoint(stamp_ns=stamp + k * NS_PER_S, position_enu_m=(target[0] + 5 * k, target[1]),
                                                position_cov_m2=(25.0 * k, 0.0, 0.0, 25.0 * k)) for k in range(1, 6))))
            chunk += [PlanCommand(vehicle_id=v.id, seq=step, stamp_ns=stamp, heading_rad=0.0, turn_rate_rad_s=0.0,
                                  airspeed_mps=25.0, altitude_m=200.0, planner="ga_k5",
                                  planned_path_enu_m=tuple((float(p[0]) + 25 * k, float(p[1])) for k in range(1, 6)))
                      for v, p in zip(vehicles, xy)]
        chunks.append(chunk)
    return chunks


def _measure(scenario: Scenario, world: World, warm_up_s: int, measure_s: int) -> dict:
    chunks = messages(scenario, warm_up_s + measure_s)
    picture = Picture(scenario, world)
    observe_us, decode_us, snapshot_ms, sizes = [], [], [], []
    count = 0
    for index, chunk in enumerate(chunks):
        if index < warm_up_s * NAV_HZ:
            for message in chunk:
                picture.observe(message)
            continue
        wire = [encode(message) for message in chunk]
        start = time.perf_counter()
        for payload, encoding in wire:
            decode(payload, encoding)
        decode_us.append((time.perf_counter() - start) / len(chunk) * 1e6)
        start = time.perf_counter()
        for message in chunk:
            picture.observe(message)
        observe_us.append((time.perf_counter() - start) / len(chunk) * 1e6)
        count += len(chunk)
        start = time.perf_counter()
        tracks, status = picture.snapshot()
        size = len(encode_json(tracks)) + len(encode_json(status))
        snapshot_ms.append((time.perf_counter() - start) * 1e3)
        sizes.append(size)
    per_s = count / measure_s
    observe, snapshot = statistics.median(observe_us), statistics.median(snapshot_ms)
    return {
        "messages_per_s": per_s, "observe_us_median": observe, "decode_us_median": statistics.median(decode_us),
        "observe_over_decode": observe / statistics.median(decode_us),
        "snapshot_ms_median": snapshot, "snapshot_ms_p99": float(np.percentile(snapshot_ms, 99)),
        "snapshot_kib": statistics.median(sizes) / 1024,
        "core_share": (observe * per_s * 1e-6) + (statistics.mean(snapshot_ms) * SNAPSHOT_HZ * 1e-3),
        "trail_points": len(json.loads(encode_json(tracks))["vehicles"][0]["trail"]),
    }


def run_benchmark(scenario: Scenario, world: World, vehicle_counts: Sequence[int] = (3, 10, 100),
                  warm_up_s: int = 600, measure_s: int = 20, command: str = "",
                  progress: Callable[[str], None] | None = None) -> dict:
    """Every team size; returns the report (see :func:`format_report` for the keys)."""
    say = progress or (lambda _msg: None)
    rows = {}
    for count in vehicle_counts:
        say(f"{count} vehicles: {warm_up_s} s to fill the trails, then {measure_s} s measured")
        rows[str(count)] = _measure(with_vehicles(scenario, count), world, warm_up_s, measure_s)
    return {"scenario": scenario.name, "command": command, "warm_up_s": warm_up_s, "measure_s": measure_s,
            "snapshot_hz": SNAPSHOT_HZ, "vehicles": rows}


def format_report(report: dict) -> str:
    """The table."""
    lines = [f"live map cost on the daemon's loop: {report['command'] or 'gcs-bench livemap'}",
             f"trails full ({report['warm_up_s']} s), {report['measure_s']} s measured, snapshots at "
             f"{report['snapshot_hz']:g} Hz",
             f"{'vehicles':>8}{'msgs/s':>9}{'observe us':>12}{'decode us':>11}{'ratio':>7}{'snapshot ms':>13}"
             f"{'p99':>7}{'KiB':>7}{'core share':>12}"]
    for count, r in report["vehicles"].items():
        lines.append(f"{count:>8}{r['messages_per_s']:>9.0f}{r['observe_us_median']:>12.1f}{r['decode_us_median']:>11.1f}"
                     f"{r['observe_over_decode']:>7.2f}{r['snapshot_ms_median']:>13.2f}{r['snapshot_ms_p99']:>7.2f}"
                     f"{r['snapshot_kib']:>7.0f}{r['core_share'] * 100:>11.2f}%")
    lines.append("observe: per message fed to the picture; decode: the codec on the same messages (the daemon's "
                 "ingest pays it already); core share: observing every message plus five snapshots a second")
    return "\n".join(lines)


def write_plots(report: dict, directory: Path) -> list[Path]:
    """``livemap_cost.png`` (per message and per snapshot, by team size) and ``livemap.md``."""
    plt = pyplot()
    written: list[Path] = []
    counts = list(report["vehicles"])
    rows = list(report["vehicles"].values())
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    for offset, key, label in ((-0.2, "observe_us_median", "picture.observe"), (0.2, "decode_us_median",
                                                                               "codec decode (peer)")):
        left.bar([i + offset for i in range(len(counts))], [r[key] for r in rows], 0.4, label=label)
    left.set_xticks(range(len(counts)), counts)
    left.set_xlabel("vehicles")
    left.set_ylabel("microseconds per message (median)")
    left.legend(fontsize=8)
    right.bar(range(len(counts)), [r["snapshot_ms_median"] for r in rows], color="#1e88e5", label="median")
    right.plot(range(len(counts)), [r["snapshot_ms_p99"] for r in rows], "k_", markersize=20, label="p99")
    right.set_xticks(range(len(counts)), counts)
    right.set_xlabel("vehicles")
    right.set_ylabel("milliseconds per snapshot (build + encode)")
    right.legend(fontsize=8)
    save(fig, directory, "livemap_cost.png", written)
    table = [(int(count), r["messages_per_s"], r["observe_us_median"], r["decode_us_median"], r["observe_over_decode"],
              r["snapshot_ms_median"], r["snapshot_ms_p99"], r["snapshot_kib"], r["core_share"] * 100)
             for count, r in report["vehicles"].items()]
    write_markdown(directory, "livemap.md", "gcs-bench livemap: the live map's cost on the daemon's loop", [
        ("By team size", ["vehicles", "messages/s", "observe us", "decode us (peer)", "observe / decode",
                          "snapshot ms (median)", "snapshot ms (p99)", "snapshot KiB", "core share %"], table),
    ], [report["command"] or "gcs-bench livemap"], written)
    return written
