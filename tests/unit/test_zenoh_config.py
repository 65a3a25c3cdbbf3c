"""``--zenoh-config FILE``: zenoh's own configuration passes through, the explicit options win, scouting stays off."""

from __future__ import annotations

import argparse
import json

import pytest

from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, add_zenoh_arguments, required_settings, settings_from_arguments

FILE = """{
  // zenoh's JSON5: comments and trailing commas allowed
  mode: "client",
  connect: { endpoints: ["tcp/127.0.0.1:7999"], },
  scouting: { multicast: { enabled: true } },
  transport: { auth: { usrpwd: { user: "gcs", password: "s3cret" } } },
}
"""


def _parse(*argv: str, listen=(DEFAULT_ENDPOINT,), connect=()) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_zenoh_arguments(parser, listen=listen, connect=connect)
    return parser.parse_args(list(argv))


def _config(tmp_path, text: str = FILE) -> str:
    path = tmp_path / "zenoh.json5"
    path.write_text(text)
    return str(path)


def test_the_files_mode_endpoints_and_credentials_are_used_and_scouting_stays_off(tmp_path) -> None:
    settings = settings_from_arguments(_parse("--zenoh-config", _config(tmp_path)))
    assert settings.mode == "client" and list(settings.connect) == ["tcp/127.0.0.1:7999"]
    assert list(settings.listen) == []  # the file says nothing, and a client does not listen
    peer = settings_from_arguments(_parse("--zenoh-config", _config(tmp_path), "--zenoh-mode", "peer"))
    assert list(peer.listen) == [DEFAULT_ENDPOINT]  # a peer gets the command's default
    config = settings.config()
    assert json.loads(config.get_json("transport/auth/usrpwd/user")) == "gcs"
    assert json.loads(config.get_json("transport/auth/usrpwd/password")) == "s3cret"
    assert json.loads(config.get_json("scouting/multicast/enabled")) is False
    assert json.loads(config.get_json("mode")) == "client"


def test_explicit_options_override_the_file(tmp_path) -> None:
    settings = settings_from_arguments(_parse("--zenoh-config", _config(tmp_path), "--zenoh-mode", "peer",
                                              "--zenoh-connect", "tcp/127.0.0.1:7001", "--zenoh-listen",
                                              "tcp/127.0.0.1:7002"))
    assert (settings.mode, list(settings.connect), list(settings.listen)) == (
        "peer", ["tcp/127.0.0.1:7001"], ["tcp/127.0.0.1:7002"])
    config = settings.config()
    assert json.loads(config.get_json("connect/endpoints")) == ["tcp/127.0.0.1:7001"]
    assert json.loads(config.get_json("transport/auth/usrpwd/user")) == "gcs"  # the rest still from the file


def test_without_a_file_nothing_changes() -> None:
    settings = settings_from_arguments(_parse(connect=("tcp/127.0.0.1:7447",), listen=()))
    assert (settings.mode, list(settings.connect), list(settings.listen), settings.config_file) == (
        "peer", ["tcp/127.0.0.1:7447"], [], None)
    assert settings_from_arguments(_parse("--zenoh-mode", "none")) is None


def test_a_command_that_needs_zenoh_refuses_zenoh_mode_none_by_name() -> None:
    with pytest.raises(ValueError, match="gcs record needs zenoh"):
        required_settings(_parse("--zenoh-mode", "none"), "gcs record")
    assert required_settings(_parse(connect=("tcp/127.0.0.1:7447",), listen=()), "gcs record").mode == "peer"


@pytest.mark.parametrize("text", ["{ mode: ", "{ mode: \"sideways\" }"])
def test_a_bad_file_is_a_clear_error_naming_it(tmp_path, text: str) -> None:
    path = _config(tmp_path, text)
    with pytest.raises(ValueError, match="zenoh"):
        settings = settings_from_arguments(_parse("--zenoh-config", path))
        settings.config()
    with pytest.raises(ValueError, match="no such file"):
        settings_from_arguments(_parse("--zenoh-config", str(tmp_path / "missing.json5")))
