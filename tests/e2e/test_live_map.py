"""The live map in headless Chromium: during a short ``gcs demo``, and on a recording with ``gcs replay --view``.

Everything is read from the rendered page (the SVG elements' data attributes,
their on-screen boxes, the status panel), as an operator would see it; a
screenshot of each is saved under ``tests/artifacts/``.
"""

from __future__ import annotations

import json
import math
import re
import queue
import signal
import subprocess
import threading
import time
from importlib import resources
from pathlib import Path

import pytest

from gcs.config.world import build_world
from gcs.engine.tracker_factory import horizon_steps
from gcs.scenarios import load_scenario
from tests.e2e.browser import (ARTIFACTS, Browser, assert_colours_as_the_legend, assert_labels_apart, chromium_binary,
                               followed, inside, settled)
from tests.e2e.processes import script
from tests.recordings import run_recording

NO_FLY = """
[[restricted]]
name = "hospital"
polygon_enu_m = [[2500.0, 2500.0], [2900.0, 2500.0], [2900.0, 2900.0], [2500.0, 2900.0]]
floor_m = 0.0
ceiling_m = 1000.0
"""

PAGE_STATE = """JSON.stringify((() => {
  const shown = (e) => { const r = e.getBoundingClientRect(); return r.width > 0 && r.height > 0; };
  const vehicles = [...document.querySelectorAll('#layer-vehicles .vehicle')].map((e) => ({
    id: e.id, x: Number(e.dataset.x), y: Number(e.dataset.y), link: e.dataset.link,
    drawn: shown(e.querySelector('.vehicle-body'))}));
  const track = document.querySelector('#layer-track .track');
  const prediction = document.querySelector('#layer-track .prediction');
  return {
    snapshots: Number(document.body.dataset.snapshots), connected: document.body.dataset.connected,
    mode: document.body.dataset.mode,
    buildings: document.querySelectorAll('#layer-world .building').length,
    no_fly: [...document.querySelectorAll('#layer-world .nofly')].map((e) => e.dataset.name),
    vehicles: vehicles,
    track: track && {x: Number(track.dataset.x), y: Number(track.dataset.y), seq: Number(track.dataset.seq),
                     rx: Number(track.dataset.rx), drawn: shown(track.querySelector('.track-ellipse'))},
    prediction_points: prediction ? Number(prediction.dataset.points) : 0,
    plans: [...document.querySelectorAll('#layer-plans .plan')].map((e) => e.id),
    trails: document.querySelectorAll('#layer-trails .trail-of').length,
    truth: document.querySelectorAll('#layer-truth .truth').length,
    rmse: document.getElementById('rmse').dataset.rmse || null,
    panel_links: [...document.querySelectorAll('#status-vehicles tbody tr')].map((e) => e.dataset.link),
    replay_controls: !document.getElementById('replay-controls').hidden,
    play_button: document.getElementById('play').textContent,
    ended: !document.getElementById('replay-end').hidden,
  };
})())"""


def _state(browser: Browser) -> dict:
    return json.loads(browser.evaluate(PAGE_STATE))


def _wait_state(browser: Browser, condition, what: str, timeout_s: float = 60.0) -> dict:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        state = _state(browser)
        if condition(state):
            return state
        time.sleep(0.2)
    pytest.fail(f"the page never showed {what} within {timeout_s} s; last state: {_state(browser)}")


class _Command:
    """A command run as a process: stdout read line by line on a thread, stderr to a file."""

    def __init__(self, args: list[str], stderr: Path) -> None:
        self._stderr_path = stderr
        self._stderr = open(stderr, "w")
        self.process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=self._stderr, text=True)
        self.lines: queue.Queue[str] = queue.Queue()
        self._seen: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self._seen.append(line)
            self.lines.put(line)

    def live_map_url(self, timeout_s: float = 60.0) -> str:
        """The ``live map: URL`` line the command prints."""
        deadline = time.monotonic() + timeout_s
        while (remaining := deadline - time.monotonic()) > 0:
            try:
                line = self.lines.get(timeout=remaining)
            except queue.Empty:
                break
            found = re.search(r"live map: (http://\S+)", line)
            if found:
                return found.group(1)
        pytest.fail(f"no 'live map:' line within {timeout_s} s; printed: {''.join(self._seen)!r}")

    def finish(self, wait_s: float = 0.0) -> tuple[int, str, str]:
        """Exit code, stdout and stderr, once it has exited by itself within ``wait_s`` or on SIGINT."""
        if wait_s:
            try:
                self.process.wait(timeout=wait_s)
            except subprocess.TimeoutExpired:
                pass
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self._reader.join(10)
        self._stderr.close()
        return self.process.returncode, "".join(self._seen), self._stderr_path.read_text()


def _screenshot(browser: Browser, name: str) -> Path:
    path = browser.screenshot(ARTIFACTS / name)
    print(f"screenshot: {path}")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return path


def _moved(before: dict, after: dict) -> dict[str, float]:
    start = {v["id"]: (v["x"], v["y"]) for v in before["vehicles"]}
    return {v["id"]: math.dist(start[v["id"]], (v["x"], v["y"])) for v in after["vehicles"]}


def test_demo_page_draws_the_city_vehicles_plans_and_track_and_they_move(tmp_path: Path) -> None:
    binary = chromium_binary()
    scenario = tmp_path / "urban_with_no_fly.toml"
    shipped = resources.files("gcs.scenarios").joinpath("wang2012_urban.toml").read_text()
    scenario.write_text(shipped + NO_FLY)
    demo = _Command([script("gcs"), "demo", "--scenario", str(scenario), "--duration", "40", "--rate", "4",
                     "--http", "127.0.0.1:0"], tmp_path / "demo.log")
    try:
        url = demo.live_map_url()
        assert url.startswith("http://127.0.0.1:")
        with Browser(binary) as browser:
            browser.open(url)
            first = _wait_state(browser, lambda s: s["track"] is not None and len(s["plans"]) == 3 and s["truth"]
                                and all(v["drawn"] for v in s["vehicles"]) and len(s["vehicles"]) == 3,
                                "three vehicles, their plans, a track and the truth")
            framed = settled(browser, lambda g: all(v["link"] == "ok" for v in g["vehicles"]), "the first view settled")
            pixels = browser.pixels(ARTIFACTS / "live_map_demo_first.png")
            later = _wait_state(browser, lambda s: s["track"]["seq"] >= first["track"]["seq"] + 2
                                and min(_moved(first, s).values()) > 20.0, "the vehicles and the track moving")
            _screenshot(browser, "live_map_demo.png")
    finally:
        code, stdout, stderr = demo.finish(wait_s=120.0)  # the demo ends by itself after its 40 simulated seconds
    assert code == 0, stderr[-3000:]
    assert first["connected"] == "true" and first["mode"] == "live"
    assert first["buildings"] == 400 and first["no_fly"] == ["hospital"]
    assert sorted(v["id"] for v in first["vehicles"]) == ["vehicle-uav1", "vehicle-uav2", "vehicle-uav3"]
    assert {v["link"] for v in first["vehicles"]} == {"ok"} and first["panel_links"] == ["ok", "ok", "ok"]
    assert sorted(first["plans"]) == ["plan-uav1", "plan-uav2", "plan-uav3"] and first["trails"] == 3
    assert first["track"]["drawn"] and first["track"]["rx"] > 0
    assert first["prediction_points"] == horizon_steps(load_scenario("wang2012_urban"), "sight")
    assert first["rmse"] is not None and float(first["rmse"]) > 0  # the simulator's truth is known
    assert later["snapshots"] > first["snapshots"]
    assert (later["track"]["x"], later["track"]["y"]) != (first["track"]["x"], first["track"]["y"])
    # the page opens on the vehicles and the target, not on the 3 km city, each vehicle in its legend colour
    assert framed["look"] == "follow" and framed["shown"]["east"] - framed["shown"]["west"] < 3000.0 / 2.5
    assert all(inside(framed["shown"], x, y, 0.03) for x, y in followed(framed)), framed
    assert sorted(framed["legend"]) == ["uav1", "uav2", "uav3"]
    assert_colours_as_the_legend(framed, pixels)
    assert_labels_apart(framed)
    assert "steps 40;" in stdout


def test_replay_view_plays_a_recording_on_the_page_with_pause_and_speed(tmp_path: Path) -> None:
    binary = chromium_binary()
    scenario = load_scenario("wang2012_urban")
    recording = run_recording(tmp_path, scenario, build_world(scenario), duration_s=30.0, seed=6)
    viewer = _Command([script("gcs"), "replay", str(recording), "--view", "--http", "127.0.0.1:0", "--rate", "2"],
                      tmp_path / "viewer.log")
    try:
        url = viewer.live_map_url()
        with Browser(binary) as browser:
            browser.open(url)
            playing = _wait_state(browser, lambda s: s["track"] is not None and len(s["vehicles"]) == 3
                                  and s["replay_controls"], "the replay with its controls")
            assert playing["mode"] == "replay" and playing["play_button"] == "pause" and playing["buildings"] == 400
            browser.evaluate("document.getElementById('play').click()")
            paused = _wait_state(browser, lambda s: s["play_button"] == "play", "the replay paused")
            # five more snapshots reached the page while paused (a second of the server's ticks): nothing moved
            still = _wait_state(browser, lambda s: s["snapshots"] >= paused["snapshots"] + 5, "snapshots while paused")
            assert max(_moved(paused, still).values()) == 0.0 and still["track"]["seq"] == paused["track"]["seq"]
            browser.evaluate("const s = document.getElementById('speed'); s.value = '50'; "
                             "s.dispatchEvent(new Event('change')); document.getElementById('play').click()")
            ended = _wait_state(browser, lambda s: s["ended"], "the end of the recording")
            _screenshot(browser, "live_map_replay.png")
    finally:
        code, stdout, stderr = viewer.finish()  # it runs until Ctrl-C
    assert code == 130, stderr[-3000:]
    assert min(_moved(paused, ended).values()) > 20.0 and ended["track"]["seq"] > paused["track"]["seq"]
    assert ended["play_button"] == "play" and ended["rmse"] is not None
    assert "shown " in stdout and "track" in stdout

    converted = subprocess.run([script("gcs"), "replay", str(recording), "--foxglove-mcap", str(tmp_path / "map.mcap")],
                               capture_output=True, text=True, timeout=120)
    assert converted.returncode == 0, converted.stderr[-3000:]
    assert re.search(r"wrote .*map\.mcap: [1-9]\d* map messages from .*track \d+", converted.stdout), converted.stdout
