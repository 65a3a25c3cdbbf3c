"""Running a command in a network namespace of its own, with only a loopback interface.

ArduPilot SITL can send UDP multicast, so it and everything that talks to it run where no packet
can leave the machine: ``unshare -n`` (``unshare -rn``, a user namespace as well, when not root)
gives the command a fresh network namespace, whose ``lo`` is brought up with a route for multicast
before the command starts. Nothing outside the namespace can reach the processes inside it, nor
they anything outside: the command gets its input on its command line and gives its results in a
file.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

__all__ = ["in_private_network", "namespace_command", "namespace_problem", "run_private"]

_SETUP = "ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec \"$@\""


def namespace_problem() -> str | None:
    """Why a private network namespace cannot be made here (a missing program), or None."""
    missing = [name for name in ("unshare", "ip") if shutil.which(name) is None]
    if missing:
        return f"{' and '.join(missing)} not found (util-linux and iproute2)"
    return None


def namespace_command(argv: Sequence[str]) -> list[str]:
    """``argv`` run in a fresh network namespace with ``lo`` up (module docstring)."""
    unshare = ["unshare", "-n"] if os.geteuid() == 0 else ["unshare", "-rn"]
    return [*unshare, "--", "sh", "-c", _SETUP, "sh", *argv]


def in_private_network() -> bool:
    """True when this process's only network interface is the loopback (a namespace of its own)."""
    try:
        lines = Path("/proc/self/net/dev").read_text().splitlines()[2:]  # this process's namespace's interfaces
    except OSError:
        return False
    return [line.split(":", 1)[0].strip() for line in lines] == ["lo"]


def run_private(argv: Sequence[str], timeout_s: float) -> subprocess.CompletedProcess:
    """Run ``argv`` in a private network namespace and wait for it (killed after ``timeout_s``)."""
    return subprocess.run(namespace_command(argv), timeout=timeout_s, check=False)
