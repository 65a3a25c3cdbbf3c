"""Key expressions: builders, selectors, parse_key, round trips and invalid parts."""

from __future__ import annotations

import re
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from protocols import (
    DEFAULT_PREFIX,
    KEY_KINDS,
    MESSAGE_TYPE_BY_KIND,
    DaemonStatus,
    MemberTracks,
    TargetTruth,
    NavReport,
    ParsedKey,
    PlanCommand,
    ProtocolError,
    SensorReport,
    TrackEstimate,
    VehicleScenario,
    alive_key,
    alive_selector,
    encoding_for,
    member_alive_key,
    member_alive_selector,
    member_tracks_key,
    member_tracks_selector,
    nav_key,
    navs_selector,
    parse_key,
    plan_key,
    plans_selector,
    report_key,
    reports_selector,
    scenario_key,
    scenarios_selector,
    status_key,
    track_key,
    tracks_selector,
    truth_key,
    truth_selector,
    validate_id,
    validate_prefix,
)

ids = st.from_regex(r"[A-Za-z0-9_-]{1,64}", fullmatch=True)
chunks = st.from_regex(r"[A-Za-z0-9_-]{1,12}", fullmatch=True)
prefixes = st.lists(chunks, min_size=1, max_size=4).map("/".join)

BUILDERS: dict[str, Callable[..., str]] = {
    "report": report_key,
    "nav": nav_key,
    "alive": alive_key,
    "scenario": scenario_key,
    "track": track_key,
    "plan": plan_key,
}
SELECTORS: dict[str, Callable[[str], str]] = {
    "report": reports_selector,
    "nav": navs_selector,
    "alive": alive_selector,
    "scenario": scenarios_selector,
    "track": tracks_selector,
    "plan": plans_selector,
}
INVALID_IDS = ["a/b", "*", "**", "", "uav 1", "$x", "uav1\n", "a?b", "a#b", "@uav", "x" * 65, "ü"]


def matches(selector: str, key: str) -> bool:
    """Zenoh semantics for the selectors used here: ``*`` is exactly one non-empty chunk."""
    pattern = "/".join("[^/]+" if chunk == "*" else re.escape(chunk) for chunk in selector.split("/"))
    return re.fullmatch(pattern, key) is not None


def test_builders_default_prefix() -> None:
    assert DEFAULT_PREFIX == "gcs"
    assert report_key("uav1") == "gcs/vehicle/uav1/report"
    assert nav_key("uav1") == "gcs/vehicle/uav1/nav"
    assert alive_key("uav1") == "gcs/vehicle/uav1/alive"
    assert scenario_key("uav1") == "gcs/vehicle/uav1/scenario"
    assert track_key("target") == "gcs/track/target"
    assert plan_key("uav-2_b") == "gcs/plan/uav-2_b"
    assert status_key() == "gcs/daemon/status"


def test_builders_and_selectors_custom_prefix() -> None:
    assert report_key("uav1", prefix="replay/run1") == "replay/run1/vehicle/uav1/report"
    assert status_key("replay/run1") == "replay/run1/daemon/status"
    assert reports_selector("replay/run1") == "replay/run1/vehicle/*/report"
    assert navs_selector() == "gcs/vehicle/*/nav"
    assert alive_selector() == "gcs/vehicle/*/alive"
    assert scenarios_selector("replay/run1") == "replay/run1/vehicle/*/scenario"
    assert tracks_selector() == "gcs/track/*"
    assert plans_selector() == "gcs/plan/*"


def test_parse_examples() -> None:
    assert parse_key("gcs/vehicle/uav1/report") == ParsedKey(kind="report", ident="uav1")
    assert parse_key("gcs/track/target") == ParsedKey(kind="track", ident="target")
    assert parse_key("gcs/daemon/status") == ParsedKey(kind="status", ident=None)
    replayed = parse_key("replay/run1/plan/uav3", prefix="replay/run1")
    assert replayed == ParsedKey(kind="plan", ident="uav3")
    parsed = parse_key("gcs/vehicle/uav1/nav")
    with pytest.raises(AttributeError):
        parsed.kind = "plan"  # type: ignore[misc]


@settings(max_examples=200)
@given(kind=st.sampled_from(sorted(BUILDERS)), ident=ids, prefix=prefixes)
def test_round_trip_and_selector_match(kind: str, ident: str, prefix: str) -> None:
    key = BUILDERS[kind](ident, prefix=prefix)
    assert parse_key(key, prefix=prefix) == ParsedKey(kind=kind, ident=ident)  # type: ignore[arg-type]
    for other, selector in SELECTORS.items():
        assert matches(selector(prefix), key) == (other == kind), (other, key)
    assert not matches(status_key(prefix), key)


@settings(max_examples=100)
@given(prefix=prefixes)
def test_status_round_trip(prefix: str) -> None:
    assert parse_key(status_key(prefix), prefix=prefix) == ParsedKey(kind="status", ident=None)
    assert validate_prefix(prefix) == prefix


@settings(max_examples=300)
@given(
    key=st.text(max_size=40)
    | st.from_regex(r"gcs/(vehicle|track|plan|daemon)(/[^/]{0,6}){0,3}", fullmatch=True)
)
def test_parse_arbitrary_text_raises_only_protocol_error(key: str) -> None:
    try:
        parsed = parse_key(key)
    except ProtocolError as exc:
        assert exc.reason == "key" and str(exc)
        return
    rebuilt = status_key() if parsed.kind == "status" else BUILDERS[parsed.kind](parsed.ident)
    assert rebuilt == key


@pytest.mark.parametrize("bad", INVALID_IDS)
@pytest.mark.parametrize("kind", sorted(BUILDERS))
def test_invalid_ids_are_named(kind: str, bad: str) -> None:
    with pytest.raises(ProtocolError) as info:
        BUILDERS[kind](bad)
    assert repr(bad) in str(info.value)
    assert ("target_id" if kind == "track" else "vehicle_id") in str(info.value)
    assert info.value.reason == "key"


@pytest.mark.parametrize("bad", [None, 7, b"uav1"])
def test_non_string_ids(bad: object) -> None:
    with pytest.raises(ProtocolError, match=re.escape(repr(bad))):
        validate_id(bad, "vehicle_id")


@pytest.mark.parametrize(
    "bad", ["", "/gcs", "gcs/", "gcs//x", "g*s", "gcs/**", "@gcs", "gcs x", "gcs\n", "gcs/$x"]
)
def test_invalid_prefixes_are_named(bad: str) -> None:
    builds = (
        lambda: report_key("uav1", prefix=bad), lambda: status_key(bad), lambda: tracks_selector(bad)
    )
    for build in builds:
        with pytest.raises(ProtocolError, match="prefix") as info:
            build()
        assert repr(bad) in str(info.value)
    with pytest.raises(ProtocolError, match="prefix"):
        parse_key("gcs/daemon/status", prefix=bad)


@pytest.mark.parametrize(
    ("key", "named"),
    [
        ("gcs/vehicle/*/report", "'*'"),  # a selector is not a key
        ("gcs/vehicle/uav 1/report", "'uav 1'"),
        ("gcs/track/$x", "'$x'"),
        ("gcs/plan/", "''"),
        ("gcsx/vehicle/uav1/report", "prefix 'gcs'"),  # prefix must be a whole chunk
        ("other/vehicle/uav1/report", "prefix 'gcs'"),
        ("gcs/vehicle/uav1/status", "not in the key space"),
        ("gcs/vehicle/uav1/report/extra", "not in the key space"),
        ("gcs/track", "not in the key space"),
        ("gcs/daemon/status/x", "not in the key space"),
        ("gcs/plans/uav1", "not in the key space"),
    ],
)
def test_parse_invalid_keys(key: str, named: str) -> None:
    with pytest.raises(ProtocolError) as info:
        parse_key(key)
    assert named in str(info.value)


def test_parse_key_rejects_non_strings() -> None:
    with pytest.raises(ProtocolError, match="key must be a str"):
        parse_key(b"gcs/daemon/status")  # type: ignore[arg-type]


def test_kind_to_message_type() -> None:
    assert set(KEY_KINDS) == set(MESSAGE_TYPE_BY_KIND) | {"alive", "member_alive"}
    assert dict(MESSAGE_TYPE_BY_KIND) == {
        "report": SensorReport,
        "nav": NavReport,
        "scenario": VehicleScenario,
        "track": TrackEstimate,
        "plan": PlanCommand,
        "status": DaemonStatus,
        "truth": TargetTruth,
        "member": MemberTracks,
    }
    with pytest.raises(TypeError):
        MESSAGE_TYPE_BY_KIND["alive"] = SensorReport  # type: ignore[index]
    for tp in MESSAGE_TYPE_BY_KIND.values():
        assert encoding_for(tp).endswith(f"gcs.{tp.__name__}/{ {DaemonStatus: 4, SensorReport: 2}.get(tp, 1)}")


def test_federation_keys_round_trip() -> None:
    assert member_tracks_key("north", "fed") == "fed/federation/north/tracks"
    assert parse_key(member_tracks_key("north", "fed"), "fed") == ParsedKey(kind="member", ident="north")
    assert parse_key(member_alive_key("north", "fed"), "fed") == ParsedKey(kind="member_alive", ident="north")
    assert member_tracks_selector("fed") == "fed/federation/*/tracks"
    assert member_alive_selector("fed") == "fed/federation/*/alive"
    with pytest.raises(ProtocolError, match="member_id"):
        member_tracks_key("a/b", "fed")
    with pytest.raises(ProtocolError, match="federation/<id>/tracks"):
        parse_key("fed/federation/north/plans", "fed")


def test_truth_keys_round_trip() -> None:
    assert truth_key("target") == "gcs/sim/truth/target"
    assert truth_selector("replay/a") == "replay/a/sim/truth/*"
    assert parse_key("gcs/sim/truth/target") == ParsedKey(kind="truth", ident="target")
    with pytest.raises(ProtocolError, match="sim/truth"):
        parse_key("gcs/sim/other/target")
