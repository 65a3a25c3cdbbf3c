"""Opening Zenoh sessions the same way everywhere (docs/protocol.md#zenoh).

Every session this project opens has multicast scouting off (two runs on one
host would otherwise find each other) and no scouting delay. A session is a
``peer`` by default: peers on loopback need no router. The daemon listens on
:data:`DEFAULT_ENDPOINT` and the simulated vehicles connect to it; either side
may start first (a peer retries its connections in the background). A
``client`` needs its router up when it opens, and says so clearly otherwise.

Publishers use ``CongestionControl.BLOCK``: reports and commands are not
dropped under load (the default DROP loses about a fifth at saturation).

**A zenoh configuration file** (``--zenoh-config FILE``: JSON5, zenoh's own
format, see zenoh's ``DEFAULT_CONFIG.json5``) is loaded first, so that
everything zenoh can be told passes through: user/password authentication
(``transport/auth/usrpwd``: ``user`` and ``password`` on the connecting side,
``dictionary_file`` of ``user:password`` lines on the listening side), TLS
(``tls/`` endpoints and ``transport/link/tls``), leases, and so on. The
explicit options (``--zenoh-mode``, ``--zenoh-listen``, ``--zenoh-connect``)
then override the file's mode and endpoints, and the file's values are used
where they are not given; multicast scouting stays off whatever the file says.

**Port 0.** A listening endpoint may leave the port to the system
(``tcp/127.0.0.1:0``): the session is then opened with Zenoh's admin space
readable, and :func:`listening_endpoints` reads back the endpoints it bound,
so that tests and ``gcs demo`` never guess a free port.
"""

from __future__ import annotations

import json
import re
import socket
import time
from pathlib import Path
from collections.abc import Sequence
from dataclasses import dataclass

import zenoh

from protocols.codec import encode, encoding_for
from protocols.messages import Message

__all__ = ["DEFAULT_ENDPOINT", "ZenohSettings", "open_session", "declare_publisher", "publish", "has_subscribers",
           "add_zenoh_arguments",
           "settings_from_arguments", "required_settings", "query", "load_config_file", "listening_endpoints",
           "check_endpoint", "clean_error"]

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
"""Where the daemon listens and the vehicles connect unless told otherwise."""


@dataclass(frozen=True)
class ZenohSettings:
    """How to open a session.

    Attributes
    ----------
    mode : ``"peer"``, ``"client"`` or ``"router"``
    listen : sequence of str
        Endpoints to listen on, e.g. ``tcp/127.0.0.1:7447``.
    connect : sequence of str
        Endpoints to connect to.
    """

    mode: str = "peer"
    listen: Sequence[str] = ()
    connect: Sequence[str] = (DEFAULT_ENDPOINT,)
    config_file: str | None = None

    def __post_init__(self) -> None:
        if self.mode not in ("peer", "client", "router"):
            raise ValueError(f"zenoh mode must be peer, client or router, got {self.mode!r}")
        if self.mode == "client" and not self.connect:
            raise ValueError("a zenoh client needs at least one --zenoh-connect endpoint")

    def config(self) -> zenoh.Config:
        """The ``zenoh.Config`` for these settings: the configuration file's, if any, with this mode and
        these endpoints, multicast scouting off."""
        config = load_config_file(self.config_file) if self.config_file is not None else zenoh.Config()
        config.insert_json5("mode", json.dumps(self.mode))
        config.insert_json5("scouting/multicast/enabled", "false")
        config.insert_json5("scouting/delay", "0")
        config.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        config.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        if any(endpoint.endswith(":0") for endpoint in self.listen):  # for listening_endpoints()
            config.insert_json5("adminspace/enabled", "true")
        return config


_HOST_PORT_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
_OTHER_PROTOCOLS = ("unixsock-stream", "unixpipe", "serial", "vsock")
ENDPOINT_FORM = "PROTOCOL/HOST:PORT, e.g. tcp/127.0.0.1:7447"


def check_endpoint(endpoint: str, listen: bool) -> str:
    """``endpoint`` if zenoh can use it (``tcp/127.0.0.1:7447``; a port of 0 where it listens), else
    ValueError saying what is wrong: the form, the protocol, the port's range, a host to listen on that does
    not resolve."""
    text = endpoint.strip()
    protocol, sep, rest = text.partition("/")
    address = re.split(r"[?#]", rest, maxsplit=1)[0]
    if not sep or not address:
        raise ValueError(f"zenoh endpoint {endpoint!r}: expected {ENDPOINT_FORM}")
    if protocol in _OTHER_PROTOCOLS:
        return text
    if protocol not in _HOST_PORT_PROTOCOLS:
        raise ValueError(f"zenoh endpoint {endpoint!r}: unknown protocol {protocol!r}; expected one of "
                         f"{', '.join(_HOST_PORT_PROTOCOLS + _OTHER_PROTOCOLS)}")
    host, sep, port_text = address.rpartition(":")
    host = host.strip("[]")
    if not sep or not host or not port_text.isdigit():
        raise ValueError(f"zenoh endpoint {endpoint!r}: expected {protocol}/HOST:PORT")
    port, lowest = int(port_text), 0 if listen else 1
    if not lowest <= port <= 65535:
        raise ValueError(f"zenoh endpoint {endpoint!r}: port {port} is outside {lowest}-65535")
    if listen:  # an address to bind must be this machine's now; a router's name may resolve later (containers)
        try:
            socket.getaddrinfo(host, port)
        except (OSError, UnicodeError) as error:
            raise ValueError(f"zenoh endpoint {endpoint!r}: host {host!r} does not resolve ({error}); give an "
                             "address of this machine to listen on, e.g. 127.0.0.1 or 0.0.0.0") from None
    return text


def clean_error(error: object) -> str:
    """A zenoh error message without the Rust source locations and wrappers it carries."""
    text = re.sub(r"Json5Err\(Message \{ msg: \"(.*?)\", location: .*?\}\) \}\)", r"\1", str(error))
    text = re.sub(r" at /\S+?:\d+\.?", "", text)
    return " ".join(text.split())


def load_config_file(path: str) -> zenoh.Config:
    """A zenoh configuration file (JSON5, JSON or YAML by its suffix); ValueError naming the file when it cannot."""
    if not Path(path).is_file():
        raise ValueError(f"zenoh configuration file {path}: no such file")
    try:
        return zenoh.Config.from_file(path)
    except (zenoh.ZError, ValueError) as error:
        raise ValueError(f"zenoh configuration file {path}: {error}") from error


def _given_by_file(config: zenoh.Config, key: str):
    """The file's value at ``key`` (decoded JSON), or None where it leaves zenoh's default."""
    value = json.loads(config.get_json(key))
    return None if value == json.loads(zenoh.Config().get_json(key)) else value


def open_session(settings: ZenohSettings) -> zenoh.Session:
    """Open a session; a clear ``RuntimeError`` when it cannot (e.g. a client with no router)."""
    try:
        return zenoh.open(settings.config())
    except zenoh.ZError as error:
        hint = (f"; is a router listening on {', '.join(settings.connect)} (gcs router, zenohd)?"
                if settings.mode == "client" else "")
        raise RuntimeError(f"cannot open a zenoh {settings.mode} session (listen {list(settings.listen)}, "
                           f"connect {list(settings.connect)}): {clean_error(error)}{hint}") from error


def listening_endpoints(session: zenoh.Session, timeout_s: float = 5.0) -> list[str]:
    """The endpoints ``session`` listens on, with the ports the system bound (``tcp/127.0.0.1:0`` read back).

    Read from the session's own entry in Zenoh's admin space, which
    :meth:`ZenohSettings.config` makes readable when a listening port is 0;
    RuntimeError when the entry does not answer within ``timeout_s``.
    """
    selector = f"@/{session.info.zid()}/*"
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        for reply in session.get(selector, timeout=max(0.1, min(1.0, deadline - time.monotonic()))):
            if reply.ok is None:
                continue
            try:
                entry = json.loads(reply.ok.payload.to_bytes())
            except ValueError:
                continue  # another kind of entry (the link-state graph)
            if isinstance(entry, dict) and "locators" in entry:
                return [str(locator) for locator in entry["locators"]]
    raise RuntimeError("the zenoh session did not say where it listens (its admin space is not readable: "
                       "listen on a port of 0 to read the port back)")


def declare_publisher(session: zenoh.Session, key: str, message_type: type[Message]) -> zenoh.Publisher:
    """A reliable (BLOCK) publisher for one key, carrying one message type."""
    return session.declare_publisher(key, encoding=zenoh.Encoding(encoding_for(message_type)),
                                     congestion_control=zenoh.CongestionControl.BLOCK)


def publish(publisher: zenoh.Publisher, message: Message) -> int:
    """Encode (validating ranges and finiteness) and put one message; returns the payload size."""
    payload, encoding = encode(message)
    publisher.put(payload, encoding=zenoh.Encoding(encoding))
    return len(payload)


def has_subscribers(publisher: zenoh.Publisher) -> bool:
    """Whether some subscriber matches the publisher's key expression."""
    # eclipse-zenoh 1.10's stub types matching_status as bool; it is a MatchingStatus, whose .matching says it
    return bool(publisher.matching_status.matching)  # type: ignore[attr-defined]


def add_zenoh_arguments(parser, listen: Sequence[str], connect: Sequence[str], mode: str = "peer",
                        mode_help: str | None = None) -> None:
    """``--zenoh-config``, ``--zenoh-mode``, ``--zenoh-listen``, ``--zenoh-connect`` and ``--prefix`` with
    these defaults (used where neither an option nor the configuration file gives a value); ``mode_help``
    says what the default mode is, when more than its name does."""
    parser.add_argument("--zenoh-config", metavar="FILE",
                        help="zenoh configuration file (JSON5, zenoh's format), e.g. for user/password "
                             "authentication or TLS; the options below override its mode and endpoints")
    parser.add_argument("--zenoh-mode", choices=["peer", "client", "none"], default=None,
                        help="zenoh session mode; 'none' opens no session (default: the configuration file's, "
                             f"else {mode_help or mode})")
    parser.add_argument("--zenoh-listen", action="append", default=None, metavar="ENDPOINT",
                        help=f"endpoint to listen on, repeatable (default {', '.join(listen) or 'none'})")
    parser.add_argument("--zenoh-connect", action="append", default=None, metavar="ENDPOINT",
                        help=f"endpoint to connect to, repeatable (default {', '.join(connect) or 'none'})")
    parser.add_argument("--prefix", default="gcs", help="zenoh key prefix (default gcs)")
    parser.set_defaults(zenoh_default_listen=tuple(listen), zenoh_default_connect=tuple(connect),
                        zenoh_default_mode=mode)


def settings_from_arguments(args) -> ZenohSettings | None:
    """The settings :func:`add_zenoh_arguments` parsed (None for ``--zenoh-mode none``): each of mode,
    listen and connect from its option, else from the configuration file, else the default.
    ValueError for a configuration file that cannot be read."""
    if args.zenoh_mode == "none":
        return None
    path = getattr(args, "zenoh_config", None)
    file = load_config_file(path) if path is not None else None
    mode = args.zenoh_mode or (file is not None and _given_by_file(file, "mode")) or args.zenoh_default_mode
    endpoints = {}
    for side, given, default in (("listen", args.zenoh_listen, args.zenoh_default_listen),
                                 ("connect", args.zenoh_connect, args.zenoh_default_connect)):
        from_file = _given_by_file(file, f"{side}/endpoints") if file is not None else None
        if given is not None:
            endpoints[side] = tuple(given)
        elif isinstance(from_file, list):
            endpoints[side] = tuple(from_file)
        elif isinstance(from_file, dict):  # per-mode endpoints: {"router": [...], "peer": [...], "client": [...]}
            endpoints[side] = tuple(from_file.get(mode, ()))
        elif side == "listen" and mode == "client":
            endpoints[side] = ()  # a client does not listen: the command's default is for a peer
        else:
            endpoints[side] = tuple(default)
    for side, option in (("listen", "--zenoh-listen"), ("connect", "--zenoh-connect")):
        try:
            endpoints[side] = tuple(check_endpoint(e, side == "listen") for e in endpoints[side])
        except ValueError as error:
            raise ValueError(f"{option}: {error}") from None
    return ZenohSettings(mode=mode, listen=endpoints["listen"], connect=endpoints["connect"], config_file=path)


def required_settings(args, who: str) -> ZenohSettings:
    """:func:`settings_from_arguments` for a command that cannot work without Zenoh: ValueError
    ("<who> needs zenoh") for ``--zenoh-mode none``, as for an unreadable configuration file."""
    settings = settings_from_arguments(args)
    if settings is None:
        raise ValueError(f"{who} needs zenoh: --zenoh-mode peer or client, not none")
    return settings


def query(session: zenoh.Session, selector: str, timeout_s: float) -> list[zenoh.Sample]:
    """The samples queryables answer for ``selector``, asking again until one answers or ``timeout_s`` passes.

    A freshly opened session learns about remote queryables only once its
    connection is up, so a single ``get`` right after opening may find nobody.
    """
    deadline = time.monotonic() + timeout_s
    while True:
        remaining = deadline - time.monotonic()
        samples = [reply.ok for reply in session.get(selector, timeout=max(min(remaining, 1.0), 0.05))
                   if reply.ok is not None]
        if samples or time.monotonic() >= deadline:
            return samples
        time.sleep(0.1)
