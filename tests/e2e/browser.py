"""Headless Chromium for the live map's end-to-end tests, driven over the DevTools protocol on a pipe.

``--remote-debugging-pipe`` makes Chromium read DevTools commands from file
descriptor 3 and write replies and events to descriptor 4, each a JSON object
ended by a NUL byte; no WebSocket client or extra package is needed. One page
is opened and kept, so the test sees the page update itself from its event
stream (``--dump-dom`` would dump the page once, at its load event).

:func:`chromium_binary` finds Debian's ``chromium-headless-shell`` (or
``chromium``) and installs it with apt-get when missing and running as root;
otherwise the test fails with what to install (never a silent skip).
"""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

__all__ = ["chromium_binary", "Browser", "ARTIFACTS"]

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
