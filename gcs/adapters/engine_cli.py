"""The command-line flags of the engine's options (:class:`~gcs.engine.options.EngineOptions`), shared by
``gcs run``, ``gcs demo`` and ``gcs replay --process``, which decide alike given the same flags."""

from __future__ import annotations

import argparse
import math

from gcs.cli_errors import UsageError
from gcs.core.federation import FUSION_RULES
from gcs.engine.federation import FederationOptions
from gcs.engine.navigation import NAVIGATION_MODES
from protocols.errors import ProtocolError
from protocols.keys import validate_id, validate_prefix

__all__ = ["add_acceptance_arguments", "add_navigation_argument", "add_federation_arguments", "federation_options"]


def add_acceptance_arguments(parser: argparse.ArgumentParser, scope: str = "") -> None:
    """``--accept-unlisted`` and ``--max-wait``, what the engine accepts and how long a step waits, shared by
    ``gcs run``, ``gcs demo`` and ``gcs replay --process`` (``scope`` prefixes their help)."""
    parser.add_argument("--accept-unlisted", action="store_true",
                        help=scope + "also accept and fuse reports from vehicles outside the scenario's roster "
                                     "(default: rejected and counted as rejected.unknown_vehicle); they are never "
                                     "commanded")
    parser.add_argument("--max-wait", type=float, default=0.5, metavar="S",
                        help=scope + "how long a decision step waits for missing vehicles' reports once half "
                                     "have reported, in seconds of receive time (default 0.5)")


def add_navigation_argument(parser: argparse.ArgumentParser) -> None:
    """``--navigation``, shared by ``gcs run``, ``gcs demo`` and ``gcs replay --process``."""
    parser.add_argument("--navigation", choices=NAVIGATION_MODES, default="auto",
                        help="vehicle positions for fusion: skf runs feng2019's switching Kalman filter on each "
                             "vehicle's NavReports (GPS + INS) and fuses with its covariance; reported takes each "
                             "SensorReport's own position as exact; auto (default): skf when the scenario declares "
                             "GPS-denied zones, else reported")


def add_federation_arguments(parser: argparse.ArgumentParser, scope: str = "") -> None:
    """``--federation``, ``--member``, ``--area`` and ``--fusion``: the engine as one member of a federation of
    daemons (:mod:`gcs.engine.federation`), shared by ``gcs run`` and ``gcs replay --process``."""
    parser.add_argument("--federation", metavar="PREFIX", default=None,
                        help=scope + "join the federation of daemons under this key prefix: publish this team's "
                                     "tracks on PREFIX/federation/MEMBER/tracks, fuse the other members' (needs "
                                     "--member and --area, and a scenario with [multitarget])")
    parser.add_argument("--member", metavar="ID", default=None,
                        help=scope + "--federation: this daemon's member id (1-64 characters of A-Z a-z 0-9 _ -)")
    parser.add_argument("--area", metavar="X_MIN,Y_MIN,X_MAX,Y_MAX", default=None,
                        help=scope + "--federation: the area (ENU metres of the scenario's frame) whose targets "
                                     "this team keeps in sight (a negative first value: --area=-500,0,1000,3000)")
    parser.add_argument("--fusion", choices=tuple(FUSION_RULES), default="ci",
                        help=scope + "--federation: how the members' tracks of one target are fused (default ci: "
                                     "covariance intersection, safe with unknown correlations)")


def _area(text: str) -> tuple[float, float, float, float]:
    """``X_MIN,Y_MIN,X_MAX,Y_MAX`` as four finite numbers with min < max (UsageError naming the value)."""
    fix = "give X_MIN,Y_MIN,X_MAX,Y_MAX in metres with X_MIN < X_MAX and Y_MIN < Y_MAX, e.g. 0,0,1000,3000"
    try:
        values = tuple(float(part) for part in text.split(","))
    except ValueError:
        raise UsageError(f"--area {text!r}: not four numbers; {fix}") from None
    if len(values) != 4 or not all(math.isfinite(v) for v in values):
        raise UsageError(f"--area {text!r}: not four finite numbers; {fix}")
    x_min, y_min, x_max, y_max = values
    if not (x_min < x_max and y_min < y_max):
        raise UsageError(f"--area {text!r}: empty area; {fix}")
    return x_min, y_min, x_max, y_max


def federation_options(args: argparse.Namespace, multitarget: bool, scenario: str) -> FederationOptions | None:
    """The federation the flags of :func:`add_federation_arguments` describe (None without ``--federation``),
    checked: UsageError naming the flag and the fix."""
    given = {flag: getattr(args, name, None) for flag, name in
             (("--federation", "federation"), ("--member", "member"), ("--area", "area"))}
    if all(value is None for value in given.values()):
        return None
    missing = [flag for flag, value in given.items() if value is None]
    if missing:
        raise UsageError(f"{', '.join(missing)} missing: --federation, --member and --area go together "
                         "(e.g. --federation city --member west --area 0,0,1000,3000)")
    try:
        prefix = validate_prefix(args.federation)
    except ProtocolError as error:
        raise UsageError(f"--federation: {error}") from None
    try:
        member = validate_id(args.member, "member id")
    except ProtocolError as error:
        raise UsageError(f"--member: {error}") from None
    area = _area(args.area)
    if not multitarget:
        raise UsageError(f"--federation: scenario {scenario} tracks one target; a federation member tracks many: "
                         "use a scenario with [multitarget] (e.g. --scenario multitarget_urban)")
    return FederationOptions(member_id=member, area=area, prefix=prefix, fusion=getattr(args, "fusion", "ci"))
