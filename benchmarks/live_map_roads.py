"""``python -m benchmarks.live_map_roads``: what the roads cost the live map, served and drawn in headless Chromium.

For each city: the ``/api/world`` document's size with and without its roads, the
time to join the road graph into polylines (once, when the daemon or the viewer starts), and in the page the
main thread's work (Chromium's ``Performance.getMetrics`` TaskDuration: script,
style, layout and paint) to draw the world once and to draw one frame of a pan
across the whole-city view, with the roads shown and hidden (the legend's
checkbox), medians of ``--repeats``. Cities: the default 3 km city
(``wang2012_urban``'s street grid), ``helsinki_centre``, and that real city's roads
tiled ``--tiles`` x ``--tiles`` times (a larger graph of the same kind).

    nice python -m benchmarks.live_map_roads --repeats 30

Needs headless Chromium (``tests/e2e/browser.py`` finds it).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import time
import urllib.request

import numpy as np

from gcs.adapters.live_map.outputs import LiveMap
from gcs.adapters.live_map.picture_geometry import encode_json, world_geometry
from gcs.adapters.live_map.road_lines import road_lines
from gcs.config.world import build_world
from gcs.core.roads import RoadGraph
from gcs.core.world import content_bounds
from gcs.scenarios import load_scenario
from tests.e2e.browser import Browser, chromium_binary

DRAW = """(async () => {
  const frame = () => new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done)));
  const t0 = performance.now();
  drawWorld(state.world); render(); document.getElementById('layer-world').getBBox();
  await frame();
  return performance.now() - t0;
})()"""
PAN = """(async () => {
  const frame = () => new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done)));
  const v = state.view, t0 = performance.now();
  setView({...v, x: v.x + v.w / 50});
  await frame();
  return performance.now() - t0;
})()"""


def _tiled(world, tiles: int):
    """The world with its road graph repeated ``tiles`` x ``tiles`` times side by side (its buildings kept)."""
    graph = world.roads
    x0, y0, x1, y1 = graph.bounds
    a, b, one_way = [], [], []
    for i in range(tiles):
        for j in range(tiles):
            shift = np.array([i * (x1 - x0 + 50.0), j * (y1 - y0 + 50.0)])
            a.append(graph.nodes[graph.tail] + shift)
            b.append(graph.nodes[graph.head] + shift)
            one_way.append(graph.reverse < 0)
    big = RoadGraph.from_segments(np.concatenate(a), np.concatenate(b), np.concatenate(one_way))
    return dataclasses.replace(world, roads=big, bounds_m=content_bounds(world.buildings, big))


def _main_thread_ms(browser: Browser, expression: str, repeats: int) -> tuple[float, float]:
    """Median TaskDuration (ms) and median wall time to the second frame (ms) of ``expression``."""
    tasks, walls = [], []
    for _ in range(repeats):
        before = {m["name"]: m["value"] for m in browser.call("Performance.getMetrics")["metrics"]}
        wall = browser.call("Runtime.evaluate", {"expression": expression, "awaitPromise": True,
                                                 "returnByValue": True})["result"]["value"]
        after = {m["name"]: m["value"] for m in browser.call("Performance.getMetrics")["metrics"]}
        tasks.append(1000.0 * (after["TaskDuration"] - before["TaskDuration"]))
        walls.append(wall)
    return statistics.median(tasks), statistics.median(walls)


def measure(name: str, scenario, world, repeats: int) -> dict:
    document = world_geometry(scenario, world)
    started = time.perf_counter()
    road_lines(world.roads)
    build_ms = 1000.0 * (time.perf_counter() - started)
    served = encode_json(document)
    bare = encode_json({**document, "roads": []})
    segments = sum(len(r["line"]) - 1 for r in document["roads"])
    live = LiveMap.open(("127.0.0.1", 0), scenario, world)
    try:
        live.publish(0.0, force=True)
        with urllib.request.urlopen(live.url + "api/world", timeout=30) as answer:
            assert answer.read() == served
        with Browser(chromium_binary()) as browser:
            browser.open(live.url)
            browser.wait_for("document.body.dataset.snapshots > 0 && state.view", 60, "the page")
            browser.call("Performance.enable")
            browser.evaluate("document.getElementById('city').click()")
            row = {"city": name, "segments": segments, "polylines": len(document["roads"]),
                   "world_kb": len(served) / 1024, "without_roads_kb": len(bare) / 1024, "build_ms": build_ms}
            for shown in (True, False):
                browser.evaluate(f"(() => {{ const c = document.getElementById('show-roads'); "
                                 f"if (c.checked !== {str(shown).lower()}) c.click(); }})()")
                key = "shown" if shown else "hidden"
                row[f"draw_ms_{key}"], row[f"draw_wall_ms_{key}"] = _main_thread_ms(browser, DRAW, repeats)
                row[f"pan_ms_{key}"], row[f"pan_wall_ms_{key}"] = _main_thread_ms(browser, PAN, repeats)
    finally:
        live.close()
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.live_map_roads", description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=30, help="draws and pan frames per figure (default 30)")
    parser.add_argument("--tiles", type=int, default=4, help="helsinki_centre's roads tiled this many times a side")
    args = parser.parse_args(argv)
    rows = []
    for name in ("wang2012_urban", "helsinki_centre"):
        scenario = load_scenario(name)
        rows.append(measure(name, scenario, build_world(scenario), args.repeats))
    scenario = load_scenario("helsinki_centre")
    rows.append(measure(f"helsinki_centre roads x{args.tiles * args.tiles}", scenario,
                        _tiled(build_world(scenario), args.tiles), args.repeats))
    print("| city | road segments | polylines | /api/world KiB (without roads) | polylines built ms | world draw ms, roads "
          "shown / hidden | pan frame ms, shown / hidden |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['city']} | {r['segments']} | {r['polylines']} | {r['world_kb']:.1f} ({r['without_roads_kb']:.1f}) "
              f"| {r['build_ms']:.1f} | {r['draw_ms_shown']:.1f} / {r['draw_ms_hidden']:.1f} "
              f"| {r['pan_ms_shown']:.1f} / {r['pan_ms_hidden']:.1f} |")
    print(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
