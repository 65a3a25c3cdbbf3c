"""MAVLink 2 plumbing shared by the daemon and the simulated vehicles.

Importing this module selects MAVLink 2 in pymavlink (``MAVLINK20=1`` must be set
before ``pymavlink.mavutil`` is first imported; signing needs MAVLink 2) and
exposes pymavlink's default MAVLink 2 module as :data:`mavlink` (the ``all``
dialect, a superset of ``ardupilotmega`` with the GUIDED_CHANGE_* commands;
docs/mavlink.md). Connections parse with ``ardupilotmega``; the message
ids and enums are the same, but each module has its own ``MAVError`` class.

Conventions at this edge (docs/design.md, frames, units and time): latitude and longitude are
``1e7``-scaled integers, altitudes in metres relative to home, and yaw is NED
(from north, clockwise); inside the project headings are ENU (from east,
counter-clockwise). :func:`ned_yaw_from_enu_heading` is the one conversion.
"""

from __future__ import annotations

import errno
import hashlib
import math
import os
import socket
from pathlib import Path
from typing import TYPE_CHECKING

from gcs.adapters.mavlink_tcp import RetryingTcp
from gcs.adapters.mavlink_v2 import mavutil

mavlink = mavutil.mavlink
"""pymavlink's MAVLink 2 module (``all`` dialect: message classes, enums, ``MAVLink``)."""

if TYPE_CHECKING:  # the class of mavlink.MAVLink (pymavlink has no type information: it checks as Any)
    from pymavlink.dialects.v20.all import MAVLink

__all__ = [
    "ARDUPLANE_MODES",
    "ARDUPLANE_MODE_NAMES",
    "before_gps_fix",
    "GCS_SYSID",
    "mavlink",
    "mavutil",
    "ned_yaw_from_enu_heading",
    "normalise_connection",
    "check_connection",
    "open_connection",
    "bind_udp_exclusively",
    "PortInUse",
    "read_signing_key",
    "signing_key_from_passphrase",
    "sign_outgoing",
]

if mavlink.WIRE_PROTOCOL_VERSION != "2.0":  # pragma: no cover
    raise ImportError("pymavlink did not load the MAVLink 2 dialect")

GCS_SYSID = 255
"""System id of a ground station (docs/mavlink.md)."""

ARDUPLANE_MODE_NAMES: dict[int, str] = dict(mavutil.mode_mapping_apm)
"""ArduPlane custom_mode numbers to names (pymavlink's table: 12 LOITER, 15 GUIDED, ...)."""
ARDUPLANE_MODES: dict[str, int] = {name: number for number, name in ARDUPLANE_MODE_NAMES.items()}

_MAVSDK_SCHEMES = {"udpin://": "udpin:", "udpout://": "udpout:", "udp://": "udpin:", "tcpout://": "tcp:",
                   "tcpin://": "tcpin:", "tcp://": "tcp:", "serial://": ""}


def normalise_connection(connection: str) -> str:
    """A pymavlink connection string, also accepting MAVSDK's ``scheme://`` spellings.

    ``udpin://0.0.0.0:14540`` becomes ``udpin:0.0.0.0:14540``, ``tcpout://h:p``
    becomes ``tcp:h:p``; pymavlink strings (``udpout:127.0.0.1:14550``,
    ``/dev/ttyUSB0,57600``) pass unchanged.
    """
    text = connection.strip()
    if not text:
        raise ValueError("empty MAVLink connection string")
    for scheme, replacement in _MAVSDK_SCHEMES.items():
        if text.startswith(scheme):
            return replacement + text[len(scheme):]
    return text


_NETWORK_SCHEMES = {"udpin": True, "udp": True, "udpout": False, "udpbcast": False, "tcp": False, "tcpin": True}
"""pymavlink's network schemes, and whether each listens (a port of 0 lets the system choose one)."""
CONNECTION_FORMS = "udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or a serial device"


def check_connection(connection: str) -> str:
    """The normalised connection string if pymavlink can open it, else ValueError saying what is wrong and
    which forms are meant: a network scheme needs ``HOST:PORT`` with a port in 1-65535 (0 too where it
    listens, and there a host that resolves now); anything else is a serial device, which must exist."""
    text = normalise_connection(connection)
    scheme, sep, rest = text.partition(":")
    if not sep:
        if not os.path.exists(text.split(",")[0]):
            raise ValueError(f"MAVLink connection {connection!r}: no such serial device; expected {CONNECTION_FORMS}")
        return text
    if scheme not in _NETWORK_SCHEMES:
        raise ValueError(f"MAVLink connection {connection!r}: unknown scheme {scheme!r}; expected {CONNECTION_FORMS}")
    host, sep, port_text = rest.rpartition(":")
    if not sep or not host:
        raise ValueError(f"MAVLink connection {connection!r}: expected {scheme}:HOST:PORT")
    try:
        port = int(port_text)
    except ValueError:
        raise ValueError(f"MAVLink connection {connection!r}: port {port_text!r} is not a number; "
                         f"expected {scheme}:HOST:PORT") from None
    listens = _NETWORK_SCHEMES[scheme]
    if not (0 if listens else 1) <= port <= 65535:
        raise ValueError(f"MAVLink connection {connection!r}: port {port} is outside {0 if listens else 1}-65535")
    if listens:  # the address to bind must be this machine's now; a peer's name may resolve later (containers)
        try:
            socket.getaddrinfo(host, port, socket.AF_INET)
        except (OSError, UnicodeError) as error:
            raise ValueError(f"MAVLink connection {connection!r}: host {host!r} does not resolve ({error}); give "
                             "an address of this machine to listen on, e.g. 127.0.0.1 or 0.0.0.0") from None
    return text


NO_FIX_DEG = 0.01
"""A GLOBAL_POSITION_INT within this many degrees of lat = lon = 0 comes from an autopilot without a GPS fix:
it reports 0, 0, or its estimator's drift from there before the fix (about 1 km; the Gulf of Guinea off
Null Island is no place to track cars)."""


def before_gps_fix(lat_e7: int, lon_e7: int) -> bool:
    """Whether a position (1e7 degrees) is one an autopilot sends before its GPS has a fix (:data:`NO_FIX_DEG`)."""
    return abs(lat_e7) < NO_FIX_DEG * 1e7 and abs(lon_e7) < NO_FIX_DEG * 1e7


def open_connection(connection: str, source_system: int, source_component: int = 1) -> mavutil.mavfile:
    """Open a pymavlink connection (MAVLink 2, ``ardupilotmega``) with a clear error on failure.

    A TCP client (``tcp:``) connects in the background and again whenever the peer goes
    (:class:`~gcs.adapters.mavlink_tcp.RetryingTcp`): an autopilot that is not up yet is waited for.

    A UDP port to listen on (``udpin:``, ``udp:``) is bound for this connection alone
    (:func:`bind_udp_exclusively`): ValueError when another program holds it."""
    text = normalise_connection(connection)
    scheme, _, address = text.partition(":")
    try:
        if scheme in ("udpin", "udp"):
            return _listening_udp(text, address, source_system, source_component)
        if scheme == "tcp":  # an autopilot that is not up yet, or goes away, is waited for
            mavutil.set_dialect("ardupilotmega")  # as mavlink_connection(dialect=...) does
            return RetryingTcp(address, source_system=source_system, source_component=source_component)
        return mavutil.mavlink_connection(text, source_system=source_system, source_component=source_component,
                                          dialect="ardupilotmega", autoreconnect=True)
    except (OSError, ValueError) as error:
        raise ValueError(f"cannot open MAVLink connection {connection!r}: {error}") from error


class PortInUse(OSError):
    """A UDP port another socket holds (the message names the port and what to do)."""


def bind_udp_exclusively(host: str, port: int) -> socket.socket:
    """A UDP socket bound to ``host:port`` without ``SO_REUSEADDR``, so that the port is this socket's alone.

    pymavlink's ``udpin`` sets ``SO_REUSEADDR`` before it binds, and on Linux two sockets that
    both set it bind the same UDP port side by side: a second program listening there (another
    ``gcs run``, ``mavproxy.py --master=udpin:...`` on the daemon's port) starts without an error
    and takes the datagrams meant for the first. A socket bound without it is refused while any
    other socket holds the port (:class:`PortInUse`), and while it holds the port every later
    bind there is refused, ``SO_REUSEADDR`` or not. The kernel decides at the bind itself, so
    there is no window between a check and the bind for another program to slip into.
    """
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError as error:
        sock.close()
        if error.errno == errno.EADDRINUSE:
            raise PortInUse(f"UDP port {port} on {host} is in use by another program (another gcs "
                                         "run, a MAVProxy or a simulator listening there); stop it, or listen on "
                                         "another port") from None
        raise
    sock.setblocking(False)
    return sock


def _listening_udp(text: str, address: str, source_system: int, source_component: int) -> mavutil.mavfile:
    """pymavlink's ``udpin`` connection on a socket of :func:`bind_udp_exclusively`: pymavlink opens it on a
    port of the system's choosing, which is then swapped for the exclusive socket (its ``port`` and ``fd``)."""
    host, _, port = address.rpartition(":")
    sock = bind_udp_exclusively(host, int(port))
    try:
        conn = mavutil.mavlink_connection(f"udpin:{host}:0", source_system=source_system,
                                          source_component=source_component, dialect="ardupilotmega")
    except BaseException:
        sock.close()
        raise
    conn.port.close()
    conn.port, conn.fd, conn.address = sock, sock.fileno(), address
    return conn


def signing_key_from_passphrase(passphrase: str) -> bytes:
    """The 32-byte signing key MAVProxy derives from a passphrase (``signing key PASS``): sha256."""
    if not passphrase:
        raise ValueError("empty signing passphrase")
    return hashlib.sha256(passphrase.encode("utf-8")).digest()


def read_signing_key(path: str | Path) -> bytes:
    """A key file: 32 raw bytes, or 64 hexadecimal characters (whitespace ignored)."""
    data = Path(path).read_bytes()
    if len(data) == 32:
        return data
    text = data.decode("ascii", errors="replace").strip()
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) != 32:
        raise ValueError(f"{path}: a signing key file holds 32 raw bytes or 64 hex characters")
    return key


def sign_outgoing(mav: MAVLink, key: bytes, link_id: int, timestamp_10us: int) -> None:
    """Sign every message ``mav`` sends with ``key`` (pymavlink's ``setup_signing`` for a bare encoder).

    ``timestamp_10us`` is the MAVLink signing timestamp (10 us units since
    2015-01-01); it must not go backwards between runs with the same key.
    """
    if len(key) != 32:
        raise ValueError("a MAVLink signing key is 32 bytes")
    mav.signing.secret_key = key
    mav.signing.sign_outgoing = True
    mav.signing.link_id = link_id
    mav.signing.timestamp = timestamp_10us


def ned_yaw_from_enu_heading(angle_rad: float) -> float:
    """ENU heading (from east, counter-clockwise) <-> NED yaw (from north, clockwise), in (-pi, pi].

    The map ``a -> pi/2 - a`` is its own inverse, so the same function converts both ways.
    """
    wrapped = math.remainder(0.5 * math.pi - angle_rad, 2.0 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped
