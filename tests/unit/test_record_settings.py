"""Where ``gcs record`` goes: a client where it joins, a router where it listens, the traffic found without
endpoints."""

from __future__ import annotations

import pytest

from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT
from gcs.cli import build_parser
from gcs.recordings.record import check_record

ELSEWHERE = "tcp/127.0.0.1:7999"


def _where(tmp_path, *argv: str):
    args = build_parser("record").parse_args(["record", "-o", str(tmp_path / "r.mcap"), *argv])
    where = check_record(args)
    return where.zenoh.mode, tuple(where.zenoh.listen), tuple(where.zenoh.connect), where.find


@pytest.mark.parametrize(("argv", "expected"), [
    ((), ("client", (), (DEFAULT_ENDPOINT,), True)),  # join whoever listens there, else listen there
    (("--zenoh-connect", ELSEWHERE), ("client", (), (ELSEWHERE,), False)),
    (("--zenoh-listen", ELSEWHERE), ("router", (ELSEWHERE,), (), False)),  # the meeting point routes
    (("--zenoh-listen", ELSEWHERE, "--zenoh-connect", DEFAULT_ENDPOINT),
     ("router", (ELSEWHERE,), (DEFAULT_ENDPOINT,), False)),
    (("--zenoh-mode", "peer"), ("peer", (), (DEFAULT_ENDPOINT,), False)),  # asked for: a peer all the same
    (("--zenoh-mode", "peer", "--zenoh-listen", ELSEWHERE), ("peer", (ELSEWHERE,), (), False)),
])
def test_the_mode_follows_where_it_records(tmp_path, argv: tuple[str, ...], expected: tuple) -> None:
    assert _where(tmp_path, *argv) == expected


def test_a_configuration_files_mode_is_kept(tmp_path) -> None:
    config = tmp_path / "zenoh.json5"
    config.write_text('{ mode: "peer" }')
    assert _where(tmp_path, "--zenoh-config", str(config)) == ("peer", (), (DEFAULT_ENDPOINT,), False)
