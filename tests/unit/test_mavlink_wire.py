"""MAVLink edge helpers: heading conventions, connection strings, signing keys."""

from __future__ import annotations

import hashlib
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gcs.adapters.mavlink_wire import (
    ARDUPLANE_MODES,
    mavlink,
    ned_yaw_from_enu_heading,
    normalise_connection,
    read_signing_key,
    signing_key_from_passphrase,
)


@pytest.mark.parametrize(("enu", "ned"), [(0.0, math.pi / 2), (math.pi / 2, 0.0), (math.pi, -math.pi / 2),
                                          (-math.pi / 2, math.pi)])
def test_enu_heading_to_ned_yaw_known_directions(enu: float, ned: float) -> None:
    assert ned_yaw_from_enu_heading(enu) == pytest.approx(ned)


@given(st.floats(-10.0, 10.0))
def test_heading_conversion_is_its_own_inverse(angle: float) -> None:
    back = ned_yaw_from_enu_heading(ned_yaw_from_enu_heading(angle))
    assert math.isclose(math.cos(back), math.cos(angle), abs_tol=1e-9)
    assert math.isclose(math.sin(back), math.sin(angle), abs_tol=1e-9)
    assert -math.pi < ned_yaw_from_enu_heading(angle) <= math.pi


def test_connection_strings_accept_mavsdk_spellings() -> None:
    assert normalise_connection("udpin://0.0.0.0:14540") == "udpin:0.0.0.0:14540"
    assert normalise_connection("tcpout://127.0.0.1:5760") == "tcp:127.0.0.1:5760"
    assert normalise_connection("udpout:127.0.0.1:14550") == "udpout:127.0.0.1:14550"
    with pytest.raises(ValueError, match="empty"):
        normalise_connection("  ")


def test_signing_keys_match_mavproxy_and_key_files(tmp_path) -> None:
    assert signing_key_from_passphrase("secret") == hashlib.sha256(b"secret").digest()
    raw, hexed, bad = tmp_path / "raw.key", tmp_path / "hex.key", tmp_path / "bad.key"
    raw.write_bytes(bytes(range(32)))
    hexed.write_text(bytes(range(32)).hex() + "\n")
    bad.write_text("not a key")
    assert read_signing_key(raw) == read_signing_key(hexed) == bytes(range(32))
    with pytest.raises(ValueError, match="bad.key"):
        read_signing_key(bad)


def test_mavlink_2_ardupilot_dialect_and_plane_modes() -> None:
    assert mavlink.WIRE_PROTOCOL_VERSION == "2.0"
    assert mavlink.MAV_CMD_GUIDED_CHANGE_HEADING == 43002
    assert ARDUPLANE_MODES["GUIDED"] == 15 and ARDUPLANE_MODES["LOITER"] == 12
