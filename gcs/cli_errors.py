"""How the command lines (``gcs``, ``sim-vehicles``) report bad input: one line on stderr, exit status 2.

A command checks what it was given before it starts anything (its ``check``
function, registered beside its handler: :func:`set_command`), and raises
:class:`UsageError` with a message that names the bad value and says what
would be right. :func:`run_command` prints ``<prog>: error: <message>`` as one
line and returns 2; argparse's own errors take the same form
(:class:`OneLineParser`), without the usage block. What goes wrong later, once
the input was good (a router that is not there, a port another program holds),
is one clear line and status 1, printed by the command itself.

Ctrl-C (SIGINT) and SIGTERM ask a running command to stop (:func:`stop_on_signals`): it
closes what it opened, prints what it has (a summary), and :func:`run_command` then says
``<prog>: interrupted`` and returns 128 + the signal's number (130 for Ctrl-C, 143 for
SIGTERM), as a shell reports a process the signal ended. A command that installs no handler
is ended by ``KeyboardInterrupt`` with the same line and status. Output cut short by a reader
that went away (``gcs status | head``) ends the command quietly (:func:`guard_console`).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn, overload

__all__ = ["UsageError", "OneLineParser", "one_line", "run_command", "set_command", "writable_file",
           "existing_file", "positive", "stop_on_signals", "stopped_by", "guard_console", "INTERRUPTED_STATUS",
           "BROKEN_PIPE_STATUS"]

INTERRUPTED_STATUS = 128 + signal.SIGINT
"""Exit status after Ctrl-C (130), as a shell reports a process SIGINT ended."""
BROKEN_PIPE_STATUS = 128 + signal.SIGPIPE
"""Exit status when the reader of the output went away (141), as for a process SIGPIPE ended."""

_signals_received: list[int] = []
"""The signals that asked the running command to stop (:func:`stop_on_signals`), oldest first. Module state because
signal handlers are the process's: one command runs per process, and :func:`run_command` clears it."""


class UsageError(Exception):
    """Bad command-line input; the message names the value and the fix (printed as one line, status 2)."""


def one_line(text: object) -> str:
    """``text`` on one line: newlines and runs of spaces become single spaces."""
    return " ".join(str(text).split())


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (``prog: error: message; see prog --help``), status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {one_line(message)}; see {self.prog} --help\n")


def set_command(parser: argparse.ArgumentParser, handler: Callable[[argparse.Namespace], int],
                check: Callable[[argparse.Namespace], object] | None = None) -> None:
    """Register a subcommand's ``handler`` and the ``check`` of its input (raising :class:`UsageError`), which
    the handler calls first and tests call alone."""
    parser.set_defaults(handler=handler, check=check, command_prog=parser.prog)


def run_command(args: argparse.Namespace, known: tuple[type[BaseException], ...] = ()) -> int:
    """Run the parsed command: :class:`UsageError` (and the ``known`` input errors, e.g. a scenario that does
    not load) become one line on stderr and status 2; a command stopped by a signal says ``interrupted`` and
    returns 128 + its number (130 for Ctrl-C) unless it failed otherwise (its own status then)."""
    prog = getattr(args, "command_prog", None) or Path(sys.argv[0]).name
    _signals_received.clear()
    caught: tuple[type[BaseException], ...] = (UsageError, *known)
    try:
        status = args.handler(args)
    except caught as error:
        print(f"{prog}: error: {one_line(error)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return INTERRUPTED_STATUS
    signum = stopped_by()
    if signum is None:
        return status
    print(f"{prog}: interrupted", file=sys.stderr)
    return status or 128 + signum


def guard_console(prog: str, main: Callable[[], int]) -> int:
    """Run a console script's ``main``: Ctrl-C before its command runs (while modules load) is one line and
    status 130, not a traceback; a reader that went away (``| head``) ends it quietly, status 141."""
    try:
        return main()
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return INTERRUPTED_STATUS
    except BrokenPipeError:
        # Python flushes stdout again at exit, which would fail the same way: point it at /dev/null.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        return BROKEN_PIPE_STATUS


def writable_file(path: Path | None, option: str) -> Path | None:
    """``path`` if a file can be written there (its folder exists and is writable), else UsageError naming
    ``option``; None passes."""
    if path is None:
        return None
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a folder; give a file name")
    if not folder.is_dir():
        raise UsageError(f"{option} {path}: no folder {folder}; create it or give another path")
    if not os.access(folder, os.W_OK):
        raise UsageError(f"{option} {path}: folder {folder} is not writable; give another path")
    return path


def existing_file(path: Path, option: str) -> Path:
    """``path`` if it is a readable file, else UsageError naming ``option``."""
    if not path.exists():
        raise UsageError(f"{option} {path}: no such file")
    if not path.is_file():
        raise UsageError(f"{option} {path}: not a file")
    if not os.access(path, os.R_OK):
        raise UsageError(f"{option} {path}: not readable")
    return path


@overload
def positive(value: float, option: str) -> float: ...
@overload
def positive(value: float | None, option: str) -> float | None: ...


def positive(value: float | None, option: str) -> float | None:
    """``value`` if it is a finite number > 0 (or None), else UsageError naming ``option``."""
    if value is not None and not 0.0 < value < float("inf"):
        raise UsageError(f"{option} must be a finite number > 0, got {value:g}")
    return value


def stop_on_signals(stop: Callable[[], None]) -> Callable[[], None]:
    """SIGINT and SIGTERM call ``stop()``: the command's loop returns and closes what it opened, and
    :func:`run_command` reports the command interrupted. Returns a function that puts the previous
    handlers back (for a command that runs several loops, each stopped on its own)."""

    def on_signal(signum: int, frame) -> None:
        _signals_received.append(signum)
        stop()

    previous = {signum: signal.signal(signum, on_signal) for signum in (signal.SIGINT, signal.SIGTERM)}

    def restore() -> None:
        for signum, handler in previous.items():
            signal.signal(signum, handler)

    return restore


def stopped_by() -> int | None:
    """The first signal that asked the running command to stop (:func:`stop_on_signals`), or None."""
    return _signals_received[0] if _signals_received else None
