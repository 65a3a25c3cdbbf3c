"""Drive a real MAVProxy (PyPI ``MAVProxy`` 1.8.75) from a test, on 127.0.0.1.

MAVProxy runs as ``python -m MAVProxy.mavproxy`` (the same program as the
``mavproxy.py`` script, in this interpreter) on a pseudo-terminal under pexpect::

    mavproxy.py --master=udpin:127.0.0.1:PORT [--out=udpout:127.0.0.1:P ...]
                --default-modules=mode,arm,param,cmdlong --state-basedir=WORKDIR

with ``cwd``, ``HOME`` and ``--state-basedir`` all in a private work folder
(MAVProxy writes ``mav.tlog``, ``mav.tlog.raw``, parameter files and reads
``~/.mavinit.scr`` there) and ``TERM=dumb`` (no terminal escape codes).

What works and what does not (observed with MAVProxy 1.8.75, pymavlink 2.4.50):

* ``--non-interactive`` (and ``--daemon``) never read standard input, so typed
  commands are ignored: leave it out to drive the prompt. Without it SIGINT ends
  MAVProxy in about 0.1 s (exit status 1, as always).
* The pty is opened without echo, so a pattern never matches the typed command.
* Two threads write: commands and messages print on MAVProxy's main loop, the
  prompt is written again by ``input()`` on another thread after each command
  line, and ``print`` writes the text and its newline separately. So the prompt can
  land inside a line (``Waiting for heartbeat from 127.0.0.1:PORTMAV> ``, then the
  newline): patterns should end in fixed text, not ``\n``.
* Readiness: ``Waiting for heartbeat from 127.0.0.1:PORT`` (about 0.2 s after
  spawn) is printed once the master socket is bound and every module is loaded.
* A vehicle: ``Detected vehicle SYS:COMP on link N`` for every non-GCS heartbeat
  source, then ``online system SYS`` for the first one (MAVProxy's target).
* The mode is the prompt, ``LOITER> ``, written at the start of a line (or after
  the previous prompt) on the first heartbeat that carries a new mode; ``Mode
  LOITER`` is announced at most every 2 s, so it may lag. ``GPS lock at N meters``
  needs GPS_RAW_INT fix_type exactly 3 and a VFR_HUD with a non-zero alt. ``status NAME`` prints ``COUNT: NAME {field : value,
  ...}``, the last message of that type from the target (see :meth:`MavProxy.message`).
* Several vehicles on one master link: MAVProxy targets the first it hears (``online
  system N``); the prompt, ``status``, ``mode``/``guided`` and the printed
  ``Got COMMAND_ACK`` concern that target only, until ``vehicle N`` (which prints
  ``Set vehicle N``) changes it. ``GPS lock`` takes the target's VFR_HUD but the last
  GPS_RAW_INT from any vehicle. An ack addressed to another ground station (one
  behind ``--out``) is routed to it and not printed.
* MAVProxy speaks MAVLink 2 from sysid 255, component 230.

The output is read on a background thread into :attr:`MavProxy.transcript` (and
``mavproxy.out`` in the work folder), so MAVProxy never blocks on a full pty
however long a test runs without looking.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import TypeVar

import pexpect

from tests.loopback import LOCALHOST

__all__ = ["DEFAULT_MODULES", "MavProxy"]

DEFAULT_MODULES = ("mode", "arm", "param", "cmdlong")
"""The console modules a test needs: ``mode``/``guided``, ``arm``, parameters and ``long``."""

_READY = r"Waiting for heartbeat from "


def _bound_udp_port(pid: int) -> int:
    """The one UDP port process ``pid`` has bound to 127.0.0.1 (its master socket; its ``udpout`` sockets are
    not bound to an address), from /proc: the socket inodes of its open files, looked up in its net/udp."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue  # closed meanwhile
        if target.startswith("socket:["):
            inodes.add(target[len("socket:["):-1])
    with open(f"/proc/{pid}/net/udp") as table:
        rows = [line.split() for line in table.readlines()[1:]]
    ports = {int(row[1].split(":")[1], 16) for row in rows if row[9] in inodes and row[1].startswith("0100007F:")}
    if len(ports) != 1:
        raise RuntimeError(f"MAVProxy (pid {pid}) has bound {sorted(ports) or 'no'} UDP ports on 127.0.0.1, "
                           "expected its master's one")
    return ports.pop()
# A prompt MAVProxy writes when the mode changes starts a line or follows another prompt; the
# repeat that input() writes after each command may land mid-line (see the module docstring).
_PROMPT = re.compile(r"(?:^|(?<=> ))([A-Za-z0-9_()]+)> ", re.MULTILINE)
_T = TypeVar("_T")
_STATUS_FIELD = re.compile(r"(\w+) : (\[[^\]]*\]|[^,]*)(?:, |$)")


def _latest_prompt(text: str) -> str | None:
    prompts = _PROMPT.findall(text)
    return prompts[-1] if prompts else None


def _number(text: str) -> int | float | str:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


class MavProxy:
    """One MAVProxy process listening for a vehicle on ``udpin:127.0.0.1:master_port``.

    Use it as a context manager (or call :meth:`start` and :meth:`close`)::

        with MavProxy() as proxy:                  # a port the system chooses, a temporary folder
            start_vehicle(f"udpout:127.0.0.1:{proxy.master_port}")
            proxy.wait_for_vehicle(7)
            proxy.wait_for_mode("LOITER")
            proxy.command("mode GUIDED", r"Got COMMAND_ACK: DO_SET_MODE: ACCEPTED")

    :meth:`expect` reads the output in order, like pexpect: each match moves a
    cursor past it. :meth:`wait_for` (and :meth:`wait_for_vehicle`) search all the
    output so far, :meth:`command` and :meth:`message` only the output that follows
    their own command, and :meth:`wait_for_mode` the latest prompt; none of them
    moves the cursor. Timeouts are in seconds; ``None`` means the constructor's
    ``timeout``. A wait that fails raises TimeoutError (RuntimeError if MAVProxy has
    exited) with MAVProxy's last output.
    """

    def __init__(self, master_port: int | None = None, *, outs: Sequence[str] = (),
                 modules: Sequence[str] = DEFAULT_MODULES, extra_args: Sequence[str] = (),
                 workdir: str | Path | None = None, timeout: float = 60.0) -> None:
        self.master_port = 0 if master_port is None else master_port
        """The port MAVProxy listens on for the vehicle: 0 until :meth:`start` has read back the one the system
        chose, when none was given."""
        self.timeout = timeout
        self._own_workdir = workdir is None
        self.workdir = Path(tempfile.mkdtemp(prefix="mavproxy-")) if workdir is None else Path(workdir)
        self.args = [f"--master=udpin:{LOCALHOST}:{self.master_port}",
                     *(f"--out={out}" for out in outs),
                     f"--default-modules={','.join(modules)}",
                     f"--state-basedir={self.workdir}",
                     *extra_args]
        self._child: pexpect.spawn | None = None
        self._reader: threading.Thread | None = None
        self._changed = threading.Condition()
        self._text = ""
        self._cursor = 0
        self._eof = False

    # ------------------------------------------------------------------ life cycle
    @property
    def argv(self) -> list[str]:
        """The command line: this interpreter running MAVProxy's ``mavproxy.py`` module."""
        return [sys.executable, "-m", "MAVProxy.mavproxy", *self.args]

    @property
    def pid(self) -> int | None:
        """MAVProxy's process id once started (still set after :meth:`close`)."""
        return None if self._child is None else self._child.pid

    def start(self, timeout: float | None = None) -> MavProxy:
        """Spawn MAVProxy and wait until its master socket is bound and it waits for a heartbeat."""
        if self._child is not None:
            raise RuntimeError("MAVProxy is already started")
        if importlib.util.find_spec("MAVProxy") is None:
            raise RuntimeError("MAVProxy is not installed in this environment: run `make test` "
                               "(it runs pip install --no-deps MAVProxy==1.8.75)")
        self.workdir.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ, HOME=str(self.workdir), TERM="dumb", PYTHONUNBUFFERED="1")
        self._child = pexpect.spawn(self.argv[0], self.argv[1:], cwd=str(self.workdir), env=env,
                                    encoding="utf-8", codec_errors="replace", echo=False,
                                    dimensions=(50, 250))
        self._reader = threading.Thread(target=self._read, name=f"mavproxy-{self._child.pid}", daemon=True)
        self._reader.start()
        try:
            self.expect(_READY, timeout)
            if self.master_port == 0:
                self.master_port = _bound_udp_port(self._child.pid)
        except BaseException:
            self.close()
            raise
        return self

    def close(self, grace: float = 3.0) -> None:
        """Stop MAVProxy: SIGINT, then SIGKILL to its process group after ``grace`` s; reap it.

        Safe to call more than once. A temporary work folder this object made is removed.
        """
        child, reader = self._child, self._reader
        if child is not None and reader is not None:
            self._signal(child.pid, signal.SIGINT, group=False)
            reader.join(grace)
            if reader.is_alive():
                self._signal(child.pid, signal.SIGKILL, group=True)
                reader.join(grace)
            child.close(force=True)
            self._reader = None
        if self._own_workdir:
            shutil.rmtree(self.workdir, ignore_errors=True)

    def __enter__(self) -> MavProxy:
        return self.start() if self._child is None else self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.close()

    @staticmethod
    def _signal(pid: int, signum: int, group: bool) -> None:
        try:
            # pexpect makes the child a session leader, so its pid is its process group.
            (os.killpg if group else os.kill)(pid, signum)
        except ProcessLookupError:
            pass

    def _read(self) -> None:
        """Background thread: move everything MAVProxy prints into the transcript."""
        assert self._child is not None
        try:
            with open(self.workdir / "mavproxy.out", "a", encoding="utf-8") as log:
                while True:
                    try:
                        chunk = self._child.read_nonblocking(65536, timeout=0.2)
                    except pexpect.TIMEOUT:
                        continue
                    except (pexpect.EOF, OSError, ValueError):
                        return
                    chunk = chunk.replace("\r", "")
                    log.write(chunk)
                    log.flush()
                    with self._changed:
                        self._text += chunk
                        self._changed.notify_all()
        finally:
            with self._changed:
                self._eof = True
                self._changed.notify_all()

    # ------------------------------------------------------------------ output
    @property
    def transcript(self) -> str:
        """Everything MAVProxy has printed so far (carriage returns removed)."""
        with self._changed:
            return self._text

    @property
    def mode(self) -> str | None:
        """The mode in the latest prompt that starts a line, ``None`` before one.

        ``MAV`` is the prompt without a vehicle; its first appearance is often
        mid-line, so it may show only after a command.
        """
        return _latest_prompt(self.transcript)

    def expect(self, pattern: str, timeout: float | None = None) -> re.Match[str]:
        """The next match of the regular expression ``pattern`` after the cursor, waiting for it.

        A pattern should end in fixed text (``r"online system (\\d+)\\b"``, not ``r"\\d+"``), and not
        in a newline (a prompt may come between a line and its newline): output is searched as it comes.
        """
        regex = re.compile(pattern, re.MULTILINE)
        found = self._wait(lambda text: regex.search(text, self._cursor), timeout, repr(pattern))
        self._cursor = found.end()
        return found

    def wait_for(self, pattern: str, timeout: float | None = None) -> re.Match[str]:
        """The first match of ``pattern`` anywhere in the transcript, waiting for it; the cursor stays."""
        regex = re.compile(pattern, re.MULTILINE)
        return self._wait(regex.search, timeout, repr(pattern))

    def wait_for_vehicle(self, sysid: int, timeout: float | None = None) -> int:
        """Wait until MAVProxy has printed ``Detected vehicle SYSID:COMP``; returns COMP."""
        return int(self.wait_for(rf"Detected vehicle {sysid}:(\d+) on link", timeout).group(1))

    def wait_for_mode(self, mode: str, timeout: float | None = None) -> None:
        """Wait until the latest prompt is ``MODE> ``: the target's last heartbeat carried that mode."""
        self._wait(lambda text: True if _latest_prompt(text) == mode else None, timeout, f"the prompt {mode}> ")

    def _wait(self, check: Callable[[str], _T | None], timeout: float | None, what: str) -> _T:
        """Wait until ``check(transcript)`` is not ``None`` and return it.

        Raises TimeoutError when ``timeout`` passes and RuntimeError when MAVProxy
        has exited, both with its last output.
        """
        wait = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + wait
        with self._changed:
            while True:
                found = check(self._text)
                if found is not None:
                    return found
                left = deadline - time.monotonic()
                if self._eof or left <= 0:
                    error = RuntimeError if self._eof else TimeoutError
                    why = "has exited" if self._eof else f"printed nothing matching within {wait:g} s"
                    raise error(f"MAVProxy {why} (waiting for {what}); its last output:\n{self._text[-3000:]}")
                self._changed.wait(left)

    # ------------------------------------------------------------------ input
    def send(self, command: str) -> int:
        """Type ``command`` at the prompt; returns where the output after it starts in :attr:`transcript`."""
        if self._child is None:
            raise RuntimeError("MAVProxy is not started")
        with self._changed:
            start = len(self._text)
        self._child.sendline(command)
        return start

    def command(self, command: str, pattern: str, timeout: float | None = None) -> re.Match[str]:
        """Type ``command`` and wait for ``pattern`` in the output that follows it; the cursor stays."""
        regex = re.compile(pattern, re.MULTILINE)
        start = self.send(command)
        return self._wait(lambda text: regex.search(text, start), timeout, f"{pattern!r} after {command!r}")

    def message(self, msg_type: str, timeout: float | None = None) -> dict[str, int | float | str]:
        """The fields of the last ``msg_type`` MAVProxy holds from its target, asking ``status`` until it has one.

        Numbers become ``int`` or ``float``; other values stay text (a text
        field that holds ``", "`` is cut there).
        """
        wait = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + wait
        pattern = rf"\b\d+: {re.escape(msg_type)} \{{([^{{}}]*)\}}"  # one write, after a prompt
        while True:
            try:
                found = self.command(f"status {msg_type}", pattern, min(0.5, max(deadline - time.monotonic(), 0.0)))
            except TimeoutError as error:
                if time.monotonic() >= deadline:
                    raise TimeoutError(f"MAVProxy held no {msg_type} within {wait:g} s") from error
                continue
            return {name: _number(value) for name, value in _STATUS_FIELD.findall(found.group(1))}
