"""ArduPlane SITL processes: one per vehicle, each in a working folder of its own, on the ports of its instance.

``arduplane --model plane -I N`` serves MAVLink on TCP ports ``5760 + 10 N`` (SERIAL0), ``5762 + 10 N``
(SERIAL1) and ``5763 + 10 N`` (SERIAL2), one client each; it starts listening about a second after
launch and starts its simulation once a client is on SERIAL0. ``-w`` wipes the stored parameters and
``--defaults`` loads the airframe's (the ``plane.parm`` of ArduPilot's autotest, looked for beside the
binary). ``--home lat,lon,alt,yaw`` places it; ``--sysid`` is its MAVLink system id.
"""

from __future__ import annotations

import logging
import os
import shutil
import signal
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["ArduPlaneSitl", "SITL_ENV", "defaults_beside", "find_binary"]

log = logging.getLogger(__name__)

SITL_ENV = "GCS_ARDUPLANE_SITL"
"""The environment variable naming the ArduPlane SITL binary (the SITL tests run when it is set)."""
SERIAL0_PORT, PORTS_PER_INSTANCE = 5760, 10


def find_binary(path: str | os.PathLike[str] | None) -> Path:
    """The SITL binary at ``path`` (else :data:`SITL_ENV`'s), checked to be an executable file; ValueError saying
    what to give otherwise."""
    text = os.fspath(path) if path is not None else os.environ.get(SITL_ENV)
    if not text:
        raise ValueError(f"no ArduPlane SITL binary: give --sitl PATH or set {SITL_ENV}")
    binary = Path(text).expanduser()
    if not (binary.is_file() and os.access(binary, os.X_OK)):
        raise ValueError(f"ArduPlane SITL {text!r} is not an executable file; build it with "
                         "'./waf configure --board sitl && ./waf plane' in an ArduPilot checkout")
    return binary.resolve()


def defaults_beside(binary: Path) -> Path | None:
    """The autotest defaults ``plane.parm`` next to the binary, if there is one."""
    candidate = binary.parent / "plane.parm"
    return candidate if candidate.is_file() else None


@dataclass
class ArduPlaneSitl:
    """One running ArduPlane SITL (:meth:`start`; :meth:`stop` ends it and removes its working folder)."""

    binary: Path
    instance: int
    sysid: int
    home: tuple[float, float, float, float]
    """Latitude, longitude (degrees), altitude (m above sea level) and heading (degrees) of home."""
    speedup: float = 1.0
    defaults: Path | None = None
    process: subprocess.Popen | None = None
    workdir: Path = field(default_factory=lambda: Path(tempfile.mkdtemp(prefix="gcs-arduplane-")))

    def port(self, serial: int) -> int:
        """The TCP port of SERIAL0, 1 or 2."""
        return SERIAL0_PORT + PORTS_PER_INSTANCE * self.instance + (0, 2, 3)[serial]

    def connection(self, serial: int) -> str:
        """The pymavlink connection string of SERIAL0, 1 or 2."""
        return f"tcp:127.0.0.1:{self.port(serial)}"

    def start(self) -> ArduPlaneSitl:
        """Launch it (its output goes to ``sitl.log`` in its working folder)."""
        lat, lon, alt, heading = self.home
        command = [str(self.binary), "--model", "plane", "--speedup", f"{self.speedup:g}", f"-I{self.instance}",
                   "-w", "--home", f"{lat:.7f},{lon:.7f},{alt:.1f},{heading:.1f}", "--sysid", str(self.sysid)]
        if self.defaults is not None:
            command += ["--defaults", str(self.defaults)]
        with open(self.workdir / "sitl.log", "wb") as output:
            self.process = subprocess.Popen(command, cwd=self.workdir, stdout=output, stderr=subprocess.STDOUT,
                                            stdin=subprocess.DEVNULL, start_new_session=True)
        log.info("ArduPlane SITL instance %d (sysid %d) started in %s", self.instance, self.sysid, self.workdir)
        return self

    def running(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def stop(self) -> None:
        """End the process (SIGTERM, then SIGKILL after 5 s) and remove the working folder (idempotent)."""
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        shutil.rmtree(self.workdir, ignore_errors=True)
