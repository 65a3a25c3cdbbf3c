"""The live map's HTTP server: static page, JSON snapshots and Server-Sent Events.

Standard library only (:class:`http.server.ThreadingHTTPServer`), one daemon
thread for the accept loop and one per connection. The producer (the daemon's
loop, or the replay clock) never waits on it: :meth:`LiveMapServer.publish`
stores the newest snapshot (immutable JSON bytes) under a lock and wakes the
event streams; every stream sends the newest snapshot it has not sent yet, so
a slow client skips intermediate snapshots instead of queueing them.

Routes
------
``GET /``, ``/style.css``, ``/view.js``, ``/labels.js``, ``/roads.js``, ``/federation.js``, ``/draw.js``, ``/app.js``
    The page (package data in ``static/``; no CDN, works offline).
``GET /api/world``
    Static geometry: city rectangle, buildings, no-fly zones.
``GET /api/tracks``, ``GET /api/status``
    The newest snapshot documents (``docs/live_map.md``).
``GET /events``
    ``text/event-stream``: ``event: snapshot`` with ``{"tracks": ..., "status": ...}``
    whenever a newer snapshot is published, a comment every
    :data:`KEEPALIVE_S` otherwise.
``POST /api/replay``
    Replay controls, ``{"action": "play"|"pause"|"restart", "speed": R}``; only
    when the server was given a ``control`` callable (``gcs replay --view``).

Bad requests get a JSON error with status 400/404/413/503 and are counted
(:attr:`LiveMapServer.counters`); nothing a client sends can stop the server.
"""

from __future__ import annotations

import json
import logging
import threading
from collections import Counter
from collections.abc import Callable
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources

__all__ = ["DEFAULT_HTTP", "LiveMapServer", "parse_http_address", "KEEPALIVE_S", "MAX_STREAMS"]

log = logging.getLogger(__name__)

DEFAULT_HTTP = "127.0.0.1:8765"
"""Where the page is served unless told otherwise (``--http``)."""
KEEPALIVE_S = 15.0
"""An event stream sends a comment after this long without a new snapshot (proxies close idle streams)."""
MAX_STREAMS = 32
"""Event streams served at once; more get 503."""
MAX_BODY_BYTES = 4096
SOCKET_TIMEOUT_S = 10.0
"""A client that does not read for this long is dropped (its thread must not hang forever)."""
STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
          "/index.html": ("index.html", "text/html; charset=utf-8"),
          **{f"/{name}": (name, "text/javascript; charset=utf-8")
             for name in ("view.js", "labels.js", "roads.js", "federation.js", "draw.js", "app.js")},
          "/style.css": ("style.css", "text/css; charset=utf-8")}


def parse_http_address(text: str) -> tuple[str, int] | None:
    """``HOST:PORT`` (port 0: any free port) as (host, port); ``none`` as None.

    Raises
    ------
    ValueError
        Naming what is wrong, e.g. a missing or out-of-range port.
    """
    text = text.strip()
    if text.lower() == "none":
        return None
    host, sep, port = text.rpartition(":")
    host = host.strip("[]")
    if not sep or not host:
        raise ValueError(f"--http wants HOST:PORT (e.g. {DEFAULT_HTTP}, port 0 for a free one) or none, got {text!r}")
    try:
        number = int(port)
    except ValueError:
        raise ValueError(f"--http: port {port!r} is not a number (in {text!r})") from None
    if not 0 <= number <= 65535:
        raise ValueError(f"--http: port {number} is outside 0..65535")
    return host, number


def _static(name: str) -> bytes:
    return resources.files("gcs.adapters.web").joinpath("static").joinpath(name).read_bytes()


class LiveMapServer:
    """Serves the page and the newest snapshot; see the module docstring.

    Parameters
    ----------
    address : (host, port)
        Port 0 picks a free port; :attr:`url` tells which.
    world : bytes
        The ``/api/world`` JSON document.
    control : callable or None
        ``control(request: dict) -> dict`` for ``POST /api/replay``; it may raise
        ValueError for a bad request (answered 400 with the message).

    Raises
    ------
    OSError
        When the address cannot be bound (in use, not local, ...).
    """

    def __init__(self, address: tuple[str, int], world: bytes,
                 control: Callable[[dict], dict] | None = None) -> None:
        self.world, self.control = world, control
        self.counters: Counter = Counter()
        self._changed = threading.Condition()
        self._version = 0
        self._tracks = b"null"
        self._status = b"null"
        self._event = b""
        self._streams = 0
        self._closing = False
        self._httpd = _LiveHTTPServer(address, _Handler, self)
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever, kwargs={"poll_interval": 0.2},
                                        name="live-map-http", daemon=True)
        self._thread.start()
        host = self._httpd.server_address[0]
        self.url = f"http://{host if isinstance(host, str) else host.decode()}:{self.port}/"
        log.info("live map on %s", self.url)

    @property
    def port(self) -> int:
        """The bound port."""
        return self._httpd.server_port

    def publish(self, tracks: bytes, status: bytes) -> None:
        """Make these the newest snapshot (JSON bytes, one line each) and wake the event streams."""
        event = b"event: snapshot\ndata: {\"tracks\":" + tracks + b",\"status\":" + status + b"}\n\n"
        with self._changed:
            self._tracks, self._status, self._event = tracks, status, event
            self._version += 1
            self._changed.notify_all()

    def latest(self) -> tuple[int, bytes, bytes]:
        """(version, tracks, status) of the newest snapshot; version 0 before the first."""
        with self._changed:
            return self._version, self._tracks, self._status

    def _next_event(self, sent: int, timeout_s: float) -> tuple[int, bytes | None]:
        """The newest event after version ``sent``, or None on timeout or when closing."""
        with self._changed:
            self._changed.wait_for(lambda: self._closing or self._version > sent, timeout=timeout_s)
            if self._closing or self._version <= sent:
                return sent, None
            return self._version, self._event

    def _enter_stream(self) -> bool:
        with self._changed:
            if self._closing or self._streams >= MAX_STREAMS:
                return False
            self._streams += 1
            return True

    def _leave_stream(self) -> None:
        with self._changed:
            self._streams -= 1

    @property
    def closing(self) -> bool:
        return self._closing

    def close(self) -> None:
        """Stop serving, end every event stream and close the socket (idempotent)."""
        with self._changed:
            if self._closing:
                return
            self._closing = True
            self._changed.notify_all()
        self._httpd.shutdown()
        self._httpd.server_close()
        self._thread.join(timeout=5.0)


class _LiveHTTPServer(ThreadingHTTPServer):
    """The HTTP server of one :class:`LiveMapServer` (``live``), which its handlers serve."""

    def __init__(self, address: tuple[str, int], handler: type[BaseHTTPRequestHandler], live: LiveMapServer) -> None:
        super().__init__(address, handler)
        self.live = live


class _Handler(BaseHTTPRequestHandler):
    """One connection; ``self.server.live`` is the :class:`LiveMapServer`."""

    server_version = "gcs-live-map"
    timeout = SOCKET_TIMEOUT_S

    @property
    def live(self) -> LiveMapServer:
        server = self.server
        if not isinstance(server, _LiveHTTPServer):
            raise TypeError(f"{type(self).__name__} serves a LiveMapServer, not a {type(server).__name__}")
        return server.live

    def log_message(self, format: str, *args) -> None:  # noqa: A002 - the base class's name
        log.debug("%s %s", self.address_string(), format % args)

    def _send(self, status: HTTPStatus, body: bytes, content_type: str = "application/json") -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _error(self, status: HTTPStatus, message: str) -> None:
        self.live.counters[f"http.rejected.{status.value}"] += 1
        self._send(status, json.dumps({"error": message}).encode())

    def do_HEAD(self) -> None:
        self.do_GET()

    def do_GET(self) -> None:
        path = self.path.split("?", 1)[0]
        live = self.live
        live.counters["http.requests"] += 1
        if path in STATIC:
            name, content_type = STATIC[path]
            self._send(HTTPStatus.OK, _static(name), content_type)
        elif path == "/api/world":
            self._send(HTTPStatus.OK, live.world)
        elif path in ("/api/tracks", "/api/status"):
            _, tracks, status = live.latest()
            self._send(HTTPStatus.OK, tracks if path == "/api/tracks" else status)
        elif path == "/events" and self.command == "HEAD":
            self.send_response(HTTPStatus.OK)
            self.send_header("Content-Type", "text/event-stream")
            self.end_headers()
        elif path == "/events":
            self._stream()
        else:
            self._error(HTTPStatus.NOT_FOUND, f"no such page: {path}")

    def _stream(self) -> None:
        live = self.live
        if not live._enter_stream():
            self._error(HTTPStatus.SERVICE_UNAVAILABLE, f"at most {MAX_STREAMS} event streams at once")
            return
        try:
            self.send_response(HTTPStatus.OK)
            self.send_header("Content-Type", "text/event-stream")
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(b"retry: 1000\n\n")
            self.wfile.flush()
            sent = 0
            while not live.closing:
                sent, event = live._next_event(sent, KEEPALIVE_S)
                if live.closing:
                    break
                self.wfile.write(event if event is not None else b": keepalive\n\n")
                self.wfile.flush()
        except OSError:  # the client went away (or stopped reading)
            live.counters["http.streams_dropped"] += 1
        finally:
            live._leave_stream()
            self.close_connection = True

    def do_POST(self) -> None:
        path = self.path.split("?", 1)[0]
        live = self.live
        live.counters["http.requests"] += 1
        if path != "/api/replay" or live.control is None:
            self._error(HTTPStatus.NOT_FOUND, f"no such endpoint: POST {path}")
            return
        try:
            length = int(self.headers.get("Content-Length", "0"))
        except ValueError:
            self._error(HTTPStatus.BAD_REQUEST, "Content-Length is not a number")
            return
        if not 0 <= length <= MAX_BODY_BYTES:
            self._error(HTTPStatus.REQUEST_ENTITY_TOO_LARGE, f"body over {MAX_BODY_BYTES} bytes")
            return
        try:
            request = json.loads(self.rfile.read(length) or b"{}")
            if not isinstance(request, dict):
                raise ValueError("the body must be a JSON object")
            answer = live.control(request)
        except ValueError as error:  # json.JSONDecodeError is one
            self._error(HTTPStatus.BAD_REQUEST, str(error))
            return
        self._send(HTTPStatus.OK, json.dumps(answer).encode())
