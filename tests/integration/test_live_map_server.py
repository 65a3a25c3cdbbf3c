"""The live map's HTTP server on 127.0.0.1: page, JSON snapshots, event streams, controls, errors, shutdown."""

from __future__ import annotations

import http.client
import json
import re
import socket
import threading
import urllib.error
import urllib.request

import pytest

from gcs.adapters.web.server import LiveMapServer, parse_http_address

WORLD = b'{"size_m": [100.0, 50.0]}'


@pytest.fixture
def server():
    live = LiveMapServer(("127.0.0.1", 0), WORLD)
    yield live
    live.close()


def _get(live: LiveMapServer, path: str) -> tuple[int, str, bytes]:
    try:
        with urllib.request.urlopen(live.url + path.lstrip("/"), timeout=10) as answer:
            return answer.status, answer.headers["Content-Type"], answer.read()
    except urllib.error.HTTPError as error:
        return error.code, error.headers["Content-Type"], error.read()


def _post(live: LiveMapServer, body: bytes, path: str = "api/replay") -> tuple[int, dict]:
    request = urllib.request.Request(live.url + path, data=body, headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=10) as answer:
            return answer.status, json.loads(answer.read())
    except urllib.error.HTTPError as error:
        return error.code, json.loads(error.read())


class _Stream:
    """An event-stream client that reads one event at a time."""

    def __init__(self, live: LiveMapServer) -> None:
        self.connection = http.client.HTTPConnection("127.0.0.1", live.port, timeout=10)
        self.connection.request("GET", "/events")
        self.response = self.connection.getresponse()

    def event(self) -> bytes:
        lines = []
        while True:
            line = self.response.fp.readline()
            if not line:
                raise EOFError("the stream ended")
            if line == b"\n":
                if any(x.startswith(b"data: ") for x in lines):
                    return next(x for x in lines if x.startswith(b"data: "))[6:].rstrip(b"\n")
                lines = []
                continue
            lines.append(line)

    def close(self) -> None:
        self.connection.close()


def test_the_page_and_its_scripts_are_served_from_the_package_without_any_cdn(server) -> None:
    status, kind, page = _get(server, "/")
    assert status == 200 and kind.startswith("text/html")
    scripts = re.findall(rb'<script src="([^"]+)"', page)
    assert scripts == [b"view.js", b"labels.js", b"roads.js", b"federation.js", b"draw.js",
                       b"app.js"] and b'href="style.css"' in page
    assert re.search(rb'(src|href)="(https?:)?//', page) is None  # nothing loaded from elsewhere
    for path, expected in [(s.decode(), "text/javascript") for s in scripts] + [("style.css", "text/css")]:
        status, kind, body = _get(server, path)
        assert status == 200 and kind.startswith(expected) and len(body) > 1000
        assert re.search(rb"(https?:)?//[a-z0-9.-]+\.[a-z]{2,}/", body) is None  # no URL of another host
    assert _get(server, "/api/world")[2] == WORLD


def test_snapshots_are_null_until_published_then_the_newest(server) -> None:
    assert _get(server, "/api/tracks")[2] == b"null"
    server.publish(b'{"n":1}', b'{"s":1}')
    server.publish(b'{"n":2}', b'{"s":2}')
    assert json.loads(_get(server, "/api/tracks")[2]) == {"n": 2}
    assert json.loads(_get(server, "/api/status")[2]) == {"s": 2}


def test_an_event_stream_gets_the_newest_snapshot_and_skips_what_it_missed(server) -> None:
    for n in range(5):
        server.publish(b'{"n":%d}' % n, b"{}")
    stream = _Stream(server)
    try:
        assert stream.response.getheader("Content-Type") == "text/event-stream"
        assert json.loads(stream.event()) == {"tracks": {"n": 4}, "status": {}}  # not 0..3
        server.publish(b'{"n":5}', b'{"ok":true}')
        assert json.loads(stream.event()) == {"tracks": {"n": 5}, "status": {"ok": True}}
    finally:
        stream.close()


def test_closing_the_server_ends_open_streams_and_frees_the_port() -> None:
    live = LiveMapServer(("127.0.0.1", 0), WORLD)
    live.publish(b"{}", b"{}")
    stream = _Stream(live)
    stream.event()
    ended = threading.Event()

    def read_to_the_end() -> None:
        try:
            while True:
                stream.event()
        except (EOFError, OSError):
            ended.set()

    reader = threading.Thread(target=read_to_the_end, daemon=True)
    reader.start()
    live.close()
    live.close()  # idempotent
    reader.join(10)
    stream.close()
    assert ended.is_set()
    with socket.socket() as probe:  # nothing listens there any more (connections may linger in TIME_WAIT)
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        probe.bind(("127.0.0.1", live.port))


def test_head_requests_get_headers_only_even_for_the_event_stream(server) -> None:
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
    try:
        for path, kind in (("/", "text/html"), ("/events", "text/event-stream")):
            connection.request("HEAD", path)
            answer = connection.getresponse()
            assert answer.status == 200 and answer.getheader("Content-Type").startswith(kind)
            assert answer.read() == b""
            connection.close()
    finally:
        connection.close()


def test_bad_requests_get_a_json_error_and_are_counted(server) -> None:
    status, _, body = _get(server, "/nope")
    assert status == 404 and "no such page" in json.loads(body)["error"]
    assert _post(server, b"{}")[0] == 404  # no controls outside a replay
    assert server.counters["http.rejected.404"] == 2


def test_replay_controls_reach_the_control_callable_and_bad_bodies_are_refused() -> None:
    seen = []

    def control(request: dict) -> dict:
        if request.get("action") == "explode":
            raise ValueError("action must be play or pause")
        seen.append(request)
        return {"playing": request.get("action") == "play"}

    live = LiveMapServer(("127.0.0.1", 0), WORLD, control=control)
    try:
        assert _post(live, b'{"action": "play"}') == (200, {"playing": True})
        assert _post(live, b'{"action": "explode"}') == (400, {"error": "action must be play or pause"})
        assert _post(live, b"{not json")[0] == 400
        assert _post(live, b"[1, 2]") == (400, {"error": "the body must be a JSON object"})
        assert _post(live, b"x" * 5000)[0] == 413
        assert seen == [{"action": "play"}]
    finally:
        live.close()


def test_an_address_in_use_is_an_os_error(server) -> None:
    with pytest.raises(OSError):
        LiveMapServer(("127.0.0.1", server.port), WORLD)


@pytest.mark.parametrize("text, expected", [("127.0.0.1:8765", ("127.0.0.1", 8765)), ("none", None),
                                            ("NONE", None), ("localhost:0", ("localhost", 0)),
                                            ("[::1]:80", ("::1", 80))])
def test_http_addresses(text, expected) -> None:
    assert parse_http_address(text) == expected


@pytest.mark.parametrize("text, message", [("8765", "HOST:PORT"), ("127.0.0.1:", "not a number"),
                                           ("127.0.0.1:http", "not a number"), ("127.0.0.1:70000", "outside")])
def test_bad_http_addresses_say_what_is_wrong(text, message) -> None:
    with pytest.raises(ValueError, match=message):
        parse_http_address(text)
