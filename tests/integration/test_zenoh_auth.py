"""Zenoh security settings passed through ``--zenoh-config`` files, on loopback.

User/password: a router (and a listening peer) with a ``dictionary_file``;
clients and peers with the right credentials exchange data, those with wrong
or no credentials do not (a client cannot even open). A daemon behind an
authenticated router answers ``gcs status`` only to a client with credentials.
TLS (when ``openssl`` is there to make a certificate): a client that trusts
the router's CA connects over ``tls/``, one that does not cannot.
"""

from __future__ import annotations

import queue
import shutil
import subprocess
import threading
import time
from contextlib import ExitStack

import pytest

from gcs.adapters.zenoh_session import ZenohSettings, listening_endpoints, open_session
from gcs.daemon.app import Daemon, DaemonOptions
from gcs.daemon.cli import query_status
from tests.integration.sim_harness import SCENARIO, WORLD
from tests.loopback import ANY_PORT_ENDPOINT


def _file(tmp_path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.fixture
def credentials(tmp_path) -> dict[str, str]:
    """Configuration files: the listening side's dictionary, right and wrong credentials."""
    dictionary = _file(tmp_path, "users.txt", "gcs:correct-horse\nuav:battery-staple\n")
    return {
        "router": _file(tmp_path, "router.json5",
                        '{ transport: { auth: { usrpwd: { dictionary_file: "%s" } } } }' % dictionary),
        "right": _file(tmp_path, "right.json5",
                       '{ transport: { auth: { usrpwd: { user: "gcs", password: "correct-horse" } } } }'),
        "wrong": _file(tmp_path, "wrong.json5",
                       '{ transport: { auth: { usrpwd: { user: "gcs", password: "battery-staple" } } } }'),
    }


def _received_within(inbox: queue.Queue, payload: bytes, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            if inbox.get(timeout=0.05) == payload:
                return True
        except queue.Empty:
            pass
    return False


def _put_until_received(session, inbox: queue.Queue, key: str, payload: bytes, timeout_s: float) -> bool:
    """Put repeatedly (the connection comes up in the background) until the listener has it."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        session.put(key, payload)
        if _received_within(inbox, payload, 0.2):
            return True
    return False


@pytest.mark.parametrize("listener_mode", ["router", "peer"])
def test_only_sessions_with_the_right_credentials_get_through(credentials, listener_mode) -> None:
    inbox: queue.Queue = queue.Queue()
    listening = ZenohSettings(mode=listener_mode, listen=(ANY_PORT_ENDPOINT,), connect=(),
                              config_file=credentials["router"])
    with open_session(listening) as listener:
        (endpoint,) = listening_endpoints(listener)
        listener.declare_subscriber("auth/**", lambda sample: inbox.put(sample.payload.to_bytes()))
        with open_session(ZenohSettings(mode="client", connect=(endpoint,), config_file=credentials["right"])) as s:
            assert _put_until_received(s, inbox, "auth/test", b"client with credentials", 10.0)
        with open_session(ZenohSettings(mode="peer", connect=(endpoint,), config_file=credentials["right"])) as s:
            assert _put_until_received(s, inbox, "auth/test", b"peer with credentials", 10.0)
        for name in ("wrong", None):
            config = credentials[name] if name else None
            with pytest.raises(RuntimeError, match="cannot open a zenoh client"):
                open_session(ZenohSettings(mode="client", connect=(endpoint,), config_file=config)).close()
            # a peer opens anyway (it retries in the background) but is never let in
            with open_session(ZenohSettings(mode="peer", connect=(endpoint,), config_file=config)) as s:
                assert not _put_until_received(s, inbox, "auth/test", f"peer {name}".encode(), 2.0)


def test_a_daemon_behind_an_authenticated_router_answers_only_clients_with_credentials(credentials) -> None:
    with ExitStack() as stack:
        router = stack.enter_context(open_session(ZenohSettings(mode="router", listen=(ANY_PORT_ENDPOINT,),
                                                                connect=(), config_file=credentials["router"])))
        (endpoint,) = listening_endpoints(router)
        daemon = Daemon(SCENARIO, WORLD, DaemonOptions(
            zenoh=ZenohSettings(mode="client", connect=(endpoint,), config_file=credentials["right"]),
            planner="orbit", plan_runner="inline"))
        thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
        thread.start()
        stack.callback(thread.join, 15)
        stack.callback(daemon.stop)
        status = query_status(ZenohSettings(mode="client", connect=(endpoint,), config_file=credentials["right"]),
                              "gcs", 20.0)
        assert status is not None and status.scenario == SCENARIO.name
        with pytest.raises(RuntimeError):
            query_status(ZenohSettings(mode="client", connect=(endpoint,), config_file=credentials["wrong"]),
                         "gcs", 2.0)
    assert not thread.is_alive()


def _openssl(*args: str) -> None:
    if shutil.which("openssl") is None:  # .ci/run installs it; a test that cannot run fails, it is not skipped
        pytest.fail("openssl is needed to make the test certificates: apt-get install openssl")
    subprocess.run(["openssl", *args], check=True, capture_output=True, timeout=60)


def test_tls_settings_pass_through(tmp_path) -> None:
    ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]
    _openssl("req", "-x509", *ec, "-keyout", str(tmp_path / "ca.key"), "-out", str(tmp_path / "ca.pem"),
             "-days", "1", "-subj", "/CN=gcs test CA")
    _openssl("req", *ec, "-keyout", str(tmp_path / "router.key"), "-out", str(tmp_path / "router.csr"),
             "-subj", "/CN=127.0.0.1")
    (tmp_path / "san.cnf").write_text("subjectAltName=IP:127.0.0.1\n")
    _openssl("x509", "-req", "-in", str(tmp_path / "router.csr"), "-CA", str(tmp_path / "ca.pem"), "-CAkey",
             str(tmp_path / "ca.key"), "-CAcreateserial", "-out", str(tmp_path / "router.pem"), "-days", "1",
             "-extfile", str(tmp_path / "san.cnf"))
    router_tls = _file(tmp_path, "router.json5", '{ transport: { link: { tls: { listen_private_key: "%s", '
                       'listen_certificate: "%s" } } } }' % (tmp_path / "router.key", tmp_path / "router.pem"))
    client_tls = _file(tmp_path, "client.json5",
                       '{ transport: { link: { tls: { root_ca_certificate: "%s" } } } }' % (tmp_path / "ca.pem"))
    inbox: queue.Queue = queue.Queue()
    with open_session(ZenohSettings(mode="router", listen=("tls/127.0.0.1:0",), connect=(),
                                    config_file=router_tls)) as router:
        (endpoint,) = listening_endpoints(router)
        router.declare_subscriber("tls/**", lambda sample: inbox.put(sample.payload.to_bytes()))
        with open_session(ZenohSettings(mode="client", connect=(endpoint,), config_file=client_tls)) as client:
            assert _put_until_received(client, inbox, "tls/test", b"over TLS", 10.0)
        with pytest.raises(RuntimeError):  # does not trust the router's certificate
            open_session(ZenohSettings(mode="client", connect=(endpoint,))).close()
