"""Headless Chromium for the live map's end-to-end tests, driven over the DevTools protocol on a pipe.

``--remote-debugging-pipe`` makes Chromium read DevTools commands from file
descriptor 3 and write replies and events to descriptor 4, each a JSON object
ended by a NUL byte; no WebSocket client or extra package is needed. One page
is opened and kept, so the test sees the page update itself from its event
stream (``--dump-dom`` would dump the page once, at its load event), and
:meth:`Browser.pixels` gives its screenshots as arrays for the tests to look at.

:func:`chromium_binary` finds Debian's ``chromium-headless-shell`` (or
``chromium``) and installs it with apt-get when missing and running as root;
otherwise the test fails with what to install (never a silent skip).
"""

from __future__ import annotations

import base64
import json
import os
import re
import select
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image  # Pillow, a dependency of matplotlib (the project's own dependency)

__all__ = ["chromium_binary", "Browser", "ARTIFACTS", "PAGE_GEOMETRY", "page_geometry", "settled", "rgb", "matching", "inside",
           "followed", "assert_colours_as_the_legend", "assert_labels_apart"]

BINARIES = ("chromium-headless-shell", "chromium", "chromium-browser")
PACKAGE = "chromium-headless-shell"
ARTIFACTS = Path(__file__).resolve().parents[1] / "artifacts"
"""Where screenshots go (gitignored)."""


def _find() -> str | None:
    return next((found for name in BINARIES if (found := shutil.which(name))), None)


def chromium_binary() -> str:
    """Path of a headless Chromium; installed from Debian's packages when missing and root."""
    found = _find()
    if found is not None:
        return found
    if os.geteuid() != 0 or shutil.which("apt-get") is None:
        pytest.fail(f"headless Chromium is missing: install the Debian package {PACKAGE} "
                    f"(sudo apt-get install {PACKAGE}); .ci/run installs it")
    environment = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for command in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", PACKAGE]):
        done = subprocess.run(command, capture_output=True, text=True, env=environment, timeout=900)
        if done.returncode != 0:
            pytest.fail(f"{' '.join(command)} failed ({done.returncode}): {done.stderr[-2000:]}")
    found = _find()
    if found is None:
        pytest.fail(f"apt-get installed {PACKAGE} but none of {BINARIES} is on PATH")
    return found


class Browser:
    """One headless Chromium with one page; use as a context manager (it is always stopped)."""

    def __init__(self, binary: str, width: int = 1280, height: int = 860) -> None:
        self._profile = tempfile.TemporaryDirectory(prefix="gcs-chromium-")
        ours_read, chrome_write = os.pipe()
        chrome_read, ours_write = os.pipe()

        def child_fds() -> None:  # Chromium expects its pipe on descriptors 3 (in) and 4 (out)
            read, write = os.dup(chrome_read), os.dup(chrome_write)
            os.dup2(read, 3)
            os.dup2(write, 4)

        command = [binary, "--headless", "--remote-debugging-pipe", "--no-sandbox", "--disable-gpu",
                   "--no-first-run", "--no-default-browser-check", "--disable-dev-shm-usage",
                   "--disable-background-networking", f"--window-size={width},{height}",
                   f"--user-data-dir={self._profile.name}", "about:blank"]
        self.process = subprocess.Popen(command, preexec_fn=child_fds, close_fds=False,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(chrome_read)
        os.close(chrome_write)
        self._read, self._write = ours_read, ours_write
        self._buffer = b""
        self._id = 0
        self.session: str | None = None

    def call(self, method: str, params: dict | None = None, session: bool = True, timeout_s: float = 30.0) -> dict:
        """Send one DevTools command and return its result (events in between are dropped)."""
        self._id += 1
        message = {"id": self._id, "method": method, "params": params or {}}
        if session and self.session is not None:
            message["sessionId"] = self.session
        os.write(self._write, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout_s
        while True:
            while b"\0" not in self._buffer:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not select.select([self._read], [], [], remaining)[0]:
                    raise TimeoutError(f"no answer to {method} within {timeout_s} s")
                chunk = os.read(self._read, 1 << 20)
                if not chunk:
                    raise RuntimeError(f"Chromium closed its pipe (exit code {self.process.poll()})")
                self._buffer += chunk
            raw, self._buffer = self._buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def open(self, url: str) -> None:
        """Open ``url`` in a new page, attach to it and wait for it to load (fails the test if it cannot)."""
        target = self.call("Target.createTarget", {"url": "about:blank"}, session=False)["targetId"]
        self.session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True},
                                 session=False)["sessionId"]
        error = self.call("Page.navigate", {"url": url}).get("errorText")
        if error:
            pytest.fail(f"Chromium could not open {url}: {error}")
        self.wait_for(f"location.href === {json.dumps(url)} && document.readyState === 'complete'", 30.0,
                      f"{url} loaded")

    def evaluate(self, expression: str):
        """The value of a JavaScript expression in the page (JSON-serialisable)."""
        result = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True})
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def wait_for(self, expression: str, timeout_s: float, what: str):
        """Poll ``expression`` until it is truthy; its value, or fail the test naming ``what``."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                value = self.evaluate(expression)
            except RuntimeError as error:  # between two documents there is no context to evaluate in
                if "execution context" not in str(error):
                    raise
                value = None
            if value:
                return value
            time.sleep(0.2)
        where = self.evaluate("location.href + ' (' + document.readyState + ')'")
        pytest.fail(f"the page never showed {what} within {timeout_s} s (the page is at {where})")

    def screenshot(self, path: Path) -> Path:
        """A PNG of the page."""
        data = self.call("Page.captureScreenshot", {"format": "png"})["data"]
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(base64.b64decode(data))
        return path

    def pixels(self, path: Path) -> np.ndarray:
        """A screenshot saved as a PNG at ``path`` and read back: (height, width, 3) 8-bit RGB, one pixel per CSS
        pixel (the page's coordinates, as ``getBoundingClientRect`` gives them)."""
        assert self.evaluate("window.devicePixelRatio") == 1, "one screenshot pixel per CSS pixel"
        with Image.open(self.screenshot(path)) as image:
            return np.asarray(image.convert("RGB"))

    def close(self) -> None:
        """Close the browser and wait for it (killed if it does not exit)."""
        try:
            if self.process.poll() is None:
                self.call("Browser.close", session=False, timeout_s=5.0)
        except (OSError, RuntimeError, TimeoutError):
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        os.close(self._read)
        os.close(self._write)
        self._profile.cleanup()

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# The page as drawn, from the browser's own geometry: the ENU rectangle on screen (the map's corners through
# the inverse of the SVG's screen transform), every mark's and label's box on screen, the legend's colours.
PAGE_GEOMETRY = """JSON.stringify((() => {
  const svg = document.getElementById('map'), r = svg.getBoundingClientRect(), inv = svg.getScreenCTM().inverse();
  const enu = (x, y) => { const p = new DOMPoint(x, y).matrixTransform(inv); return [p.x, -p.y]; };
  const [west, north] = enu(r.left, r.top), [east, south] = enu(r.right, r.bottom);
  const box = (e) => { const q = e.getBoundingClientRect(); return {x: q.x, y: q.y, w: q.width, h: q.height}; };
  const at = (e) => { const p = new DOMPoint(Number(e.dataset.x), -Number(e.dataset.y)).matrixTransform(svg.getScreenCTM());
                      return [p.x, p.y]; };  // where on screen a mark's ENU position is
  const colour = (selector, property) => getComputedStyle(document.querySelector(selector))[property];
  const clock = document.getElementById('clock'), speed = document.getElementById('speed');
  return {
    map: box(svg), shown: {west, east, south, north}, look: document.body.dataset.view, moving: svg.dataset.moving,
    snapshots: Number(document.body.dataset.snapshots),
    follow_pressed: document.getElementById('follow').getAttribute('aria-pressed'),
    city_pressed: document.getElementById('city').getAttribute('aria-pressed'),
    vehicles: [...document.querySelectorAll('#layer-vehicles .vehicle')].map((e) => ({id: e.id.replace('vehicle-', ''),
      x: Number(e.dataset.x), y: Number(e.dataset.y), stamp: Number(e.dataset.stamp), at: at(e), link: e.dataset.link,
      body: box(e.querySelector('.vehicle-body'))})),
    tracks: [...document.querySelectorAll('#layer-track .track')].map((e) => ({id: e.dataset.target,
      x: Number(e.dataset.x), y: Number(e.dataset.y), stamp: Number(e.dataset.stamp), at: at(e),
      dot: box(e.querySelector('.track-dot'))})),
    truths: [...document.querySelectorAll('#layer-truth .truth')].map((e) => ({x: Number(e.dataset.x), y: Number(e.dataset.y),
      mark: box(e)})),
    labels: [...document.querySelectorAll('#layer-labels .label')].map((e) => ({for: e.dataset.for, text: e.textContent,
      box: box(e)})),
    legend: Object.fromEntries([...document.querySelectorAll('#legend-vehicles .legend-vehicle')].map((e) =>
      [e.dataset.id, getComputedStyle(e.querySelector('.swatch')).backgroundColor])),
    swatches: {sight: colour('.swatch.sight', 'backgroundColor'), track: colour('.swatch.estimate', 'borderTopColor'),
               prediction: colour('.swatch.prediction', 'backgroundColor'), truth: colour('.swatch.truth', 'backgroundColor'),
               nofly: colour('.swatch.nofly', 'borderTopColor')},
    track_dot: document.querySelector('.track-dot') && getComputedStyle(document.querySelector('.track-dot')).fill,
    header: (() => { const h = document.querySelector('header').cloneNode(true);  // what it shows, less the lists' options
      h.querySelectorAll('select, [hidden]').forEach((e) => e.remove()); return h.textContent; })(), clock: clock.textContent, clock_s: Number(clock.dataset.seconds),
    speed: speed.value, speed_text: speed.selectedOptions[0]?.textContent ?? null,
    ended: !document.getElementById('replay-end').hidden,
  };
})())"""


def page_geometry(browser: Browser) -> dict:
    """The page as drawn (:data:`PAGE_GEOMETRY`)."""
    return json.loads(browser.evaluate(PAGE_GEOMETRY))


def settled(browser: Browser, condition=lambda g: True, what: str = "the view settled", timeout_s: float = 60.0) -> dict:
    """The geometry once the view has stopped gliding and ``condition`` holds (polled, as Browser.wait_for)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        geometry = page_geometry(browser)
        if geometry["snapshots"] > 0 and geometry.get("moving") != "true" and condition(geometry):
            return geometry
        time.sleep(0.2)
    pytest.fail(f"the page never showed {what} within {timeout_s} s; last: {page_geometry(browser)}")


def rgb(css: str) -> np.ndarray:
    """A CSS colour as the browser computes it (``rgb(r, g, b)``, ``rgba(...)``) or ``#rrggbb``, as floats."""
    if css.startswith("#"):
        return np.array([int(css[i:i + 2], 16) for i in (1, 3, 5)], dtype=float)
    found = re.fullmatch(r"rgba?\((\d+), (\d+), (\d+)(?:, [\d.]+)?\)", css)
    assert found, css
    return np.array([int(v) for v in found.groups()], dtype=float)


def matching(pixels: np.ndarray, centre: tuple[float, float], radius: int, colour: np.ndarray, tolerance: float) -> int:
    """Pixels within ``radius`` of ``centre`` (screen px) whose colour is within ``tolerance`` of ``colour``."""
    cx, cy = round(centre[0]), round(centre[1])
    window = pixels[max(cy - radius, 0):cy + radius + 1, max(cx - radius, 0):cx + radius + 1].astype(float)
    return int((np.linalg.norm(window - colour, axis=2) < tolerance).sum())


def inside(shown: dict, x: float, y: float, margin: float) -> bool:
    """Whether (x, y) is on screen, at least ``margin`` (a fraction of the width and height) from its edges."""
    mx, my = margin * (shown["east"] - shown["west"]), margin * (shown["north"] - shown["south"])
    return shown["west"] + mx <= x <= shown["east"] - mx and shown["south"] + my <= y <= shown["north"] - my


def followed(geometry: dict) -> list[tuple[float, float]]:
    """ENU positions of what the view follows: the vehicles, tracks and truths."""
    return [(v["x"], v["y"]) for v in geometry["vehicles"]] + [(t["x"], t["y"]) for t in geometry["tracks"] + geometry["truths"]]


def assert_colours_as_the_legend(geometry: dict, pixels: np.ndarray) -> None:
    """Each vehicle's pixels have the colour the legend gives it, and no other vehicle's; the vehicles' colours differ
    from each other and from every other colour of the legend (sight line, track, prediction, truth, no-fly); the
    track's dot is the legend's track colour."""
    colours = {k: rgb(c) for k, c in geometry["legend"].items()}
    others = {k: rgb(c) for k, c in geometry["swatches"].items()}
    for a, ca in colours.items():
        assert all(np.linalg.norm(ca - cb) > 80 for b, cb in colours.items() if b != a), colours
        assert all(np.linalg.norm(ca - cb) > 80 for cb in others.values()), (a, ca, others)
    for v in geometry["vehicles"]:
        assert matching(pixels, v["at"], 12, colours[v["id"]], 30) >= 20, v
        for other, c in colours.items():
            if other != v["id"]:
                assert matching(pixels, v["at"], 12, c, 30) == 0, (v["id"], other)
    for t in geometry["tracks"]:
        assert np.linalg.norm(rgb(geometry["track_dot"]) - others["track"]) < 1
        assert matching(pixels, t["at"], 6, others["track"], 30) >= 10, t


def _overlap(a: dict, b: dict) -> bool:
    return a["x"] < b["x"] + b["w"] and b["x"] < a["x"] + a["w"] and a["y"] < b["y"] + b["h"] and b["y"] < a["y"] + a["h"]


def assert_labels_apart(geometry: dict) -> None:
    """Every label's box on screen (each vehicle's and track's) meets no other label's and no mark's (a vehicle's
    arrow, a track's dot, a truth's cross)."""
    boxes = [label["box"] for label in geometry["labels"]]
    assert len(boxes) == len(geometry["vehicles"]) + len(geometry["tracks"]), geometry["labels"]
    assert all(b["w"] > 5 and b["h"] > 5 for b in boxes), boxes
    assert not any(_overlap(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:]), boxes
    marks = [v["body"] for v in geometry["vehicles"]] + [t["dot"] for t in geometry["tracks"]] + \
        [t["mark"] for t in geometry["truths"]]
    assert not any(_overlap(box, mark) for box in boxes for mark in marks), (boxes, marks)
