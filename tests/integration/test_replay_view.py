"""``gcs replay --view``'s server side: the recording plays on the page's JSON, pauses, speeds up, restarts."""

from __future__ import annotations

import json
import threading
import time
import urllib.request
from pathlib import Path

import pytest

from gcs.adapters.recording import read_recording
from gcs.config.world import build_world
from gcs.recordings.replay_view import view
from gcs.scenarios import load_scenario
from tests.recordings import run_recording

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    """20 simulated seconds of inputs with the tracks the daemon would publish."""
    return run_recording(tmp_path_factory.mktemp("view"), SCENARIO, WORLD, duration_s=20.0, seed=4)


class _Viewer:
    def __init__(self, path: Path, speed: float) -> None:
        self.stop = threading.Event()
        self.opened = threading.Event()
        self.url = ""
        self.live = None
        self.error: BaseException | None = None

        def on_open(live) -> None:
            self.url, self.live = live.url, live
            self.opened.set()

        def run() -> None:
            try:
                view(path, SCENARIO, WORLD, ("127.0.0.1", 0), speed, self.stop, on_open=on_open)
            except BaseException as error:  # noqa: BLE001 - reported by the test
                self.error = error
                self.opened.set()

        self.thread = threading.Thread(target=run, daemon=True)
        self.thread.start()
        assert self.opened.wait(30) and self.error is None, self.error

    def get(self, path: str) -> dict:
        with urllib.request.urlopen(self.url + path, timeout=10) as answer:
            return json.loads(answer.read())

    def control(self, body: dict) -> dict:
        request = urllib.request.Request(self.url + "api/replay", data=json.dumps(body).encode(),
                                         headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(request, timeout=10) as answer:
            return json.loads(answer.read())

    def wait(self, condition, what: str, timeout_s: float = 30.0) -> dict:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            status = self.get("api/status")
            if status is not None and condition(status):
                return status
            time.sleep(0.05)
        pytest.fail(f"the replay never reached {what}")

    def snapshots_later(self, count: int, timeout_s: float = 30.0) -> None:
        """Wait until the map has published ``count`` more snapshots (the replay loop has ticked that often)."""
        target = self.live.snapshots + count
        deadline = time.monotonic() + timeout_s
        while self.live.snapshots < target:
            assert time.monotonic() < deadline, f"fewer than {count} snapshots in {timeout_s} s"
            time.sleep(0.02)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(10)
        assert not self.thread.is_alive() and self.error is None, self.error


def _positions(tracks: dict) -> dict:
    return {v["id"]: (v["x"], v["y"]) for v in tracks["vehicles"]}


def test_the_recording_plays_pauses_changes_speed_and_restarts(recording: Path) -> None:
    viewer = _Viewer(recording, speed=2.0)
    try:
        viewer.wait(lambda s: s["replay"]["position_s"] > 2.0, "2 s of the recording")
        first = viewer.get("api/tracks")
        viewer.wait(lambda s: s["stamp_ns"] >= first["stamp_ns"] + 2_000_000_000, "2 more seconds")
        later = viewer.get("api/tracks")
        moved = [vid for vid, xy in _positions(later).items() if xy != _positions(first)[vid]]
        assert moved == ["uav1", "uav2", "uav3"]
        assert later["tracks"] and later["tracks"][0]["seq"] > (first["tracks"][0]["seq"] if first["tracks"] else 0)

        assert viewer.control({"action": "pause"})["playing"] is False
        viewer.wait(lambda s: s["replay"]["playing"] is False, "a snapshot after the pause")
        viewer.snapshots_later(1)  # a tick after the pause has fed up to the paused position, then nothing more
        paused = viewer.get("api/tracks")
        viewer.snapshots_later(5)  # five ticks more (a second of wall time, 2 s of recording had it played)
        assert viewer.get("api/tracks")["stamp_ns"] == paused["stamp_ns"]
        assert viewer.get("api/status")["replay"]["playing"] is False

        viewer.control({"action": "play", "speed": 50})
        end = viewer.wait(lambda s: s["replay"]["ended"], "the end of the recording")
        assert end["replay"]["playing"] is False and end["replay"]["speed"] == 50.0
        times = [r.log_time_ns for r in read_recording(recording)]
        assert end["replay"]["duration_s"] == pytest.approx((max(times) - min(times)) / 1e9, abs=0.01)
        assert end["counters"]["replayed.report"] == 60 and end["counters"]["replayed.track"] > 0
        assert end["rmse_m"] is not None and end["rmse_m"] > 0  # the recording has the truth

        viewer.control({"action": "restart", "speed": 1})
        again = viewer.wait(lambda s: s["stamp_ns"] is not None and s["stamp_ns"] < end["stamp_ns"] - 10**10,
                            "the beginning again")
        assert again["replay"]["ended"] is False and again["counters"]["replayed.report"] < 60
    finally:
        viewer.close()


def test_a_bad_control_is_answered_400_and_the_replay_goes_on(recording: Path) -> None:
    viewer = _Viewer(recording, speed=1.0)
    try:
        request = urllib.request.Request(viewer.url + "api/replay", data=b'{"speed": -3}',
                                         headers={"Content-Type": "application/json"})
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(request, timeout=10)
        assert refused.value.code == 400 and "speed must be" in json.loads(refused.value.read())["error"]
        status = viewer.wait(lambda s: s["replay"]["position_s"] > 0.5, "half a second")
        assert status["replay"]["speed"] == 1.0 and status["replay"]["playing"] is True
    finally:
        viewer.close()
