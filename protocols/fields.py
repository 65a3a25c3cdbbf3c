"""Constrained field types shared by the wire messages, and the covariance rule.

Each alias is ``typing.Annotated[<type>, msgspec.Meta(...)]``: msgspec checks the
bounds while decoding and reports a violation with the field's path
(``Expected `float` >= -100000000.0 - at `$.range_m```), and the bounds appear in
the exported JSON Schema. Units are in the alias names and in the field names that
use them.

msgspec's JSON decoder never produces a non-finite float (``NaN`` is not JSON and
``1e999`` is rejected as out of range), so every float that survives decoding is
finite; :func:`protocols.codec.encode` refuses non-finite floats on the way out.

Identifier patterns end in ``$(?!\\n)`` because Python's ``$`` also matches before a
trailing newline; the look-ahead keeps ``"uav1\\n"`` out and is valid ECMA-262, so the
JSON Schema stays usable outside Python.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated

from msgspec import Meta

from protocols.errors import ProtocolError

__all__ = [
    "COVARIANCE_SYMMETRY_RTOL",
    "check_covariance",
    "ID_REGEX",
    "ID_PATTERN",
    "INT64_MAX",
    "MAX_POSITION_M",
    "AirspeedMps",
    "AltitudeM",
    "AngleIncrementRad",
    "AngleRad",
    "CounterName",
    "Count",
    "CovarianceEntry",
    "DistanceM",
    "DurationS",
    "ElevationRad",
    "Ident",
    "LatDeg",
    "LonDeg",
    "PositionM",
    "RateRadS",
    "Seq",
    "StampNs",
    "StateValue",
    "SpeedMps",
    "StdM",
    "StdOrZeroM",
    "StdRad",
    "Text",
    "UptimeS",
    "CommandAgeMs",
    "VelocityMps",
]

#: One id chunk: vehicle, target and model/planner names (also one key chunk).
ID_REGEX = r"[A-Za-z0-9_-]{1,64}"
#: Anchored form used by ``msgspec.Meta(pattern=...)`` (which uses ``re.search``).
ID_PATTERN = rf"^{ID_REGEX}$(?!\n)"
#: Largest value of a signed 64-bit integer (MCAP and most consumers use int64/uint64).
INT64_MAX = 2**63 - 1
#: Bound on any ENU coordinate, metres.
MAX_POSITION_M = 1e8

_TWO_PI = 2.0 * math.pi

Ident = Annotated[str, Meta(pattern=ID_PATTERN, description="identifier [A-Za-z0-9_-]{1,64}")]
CounterName = Annotated[str, Meta(pattern=r"^[A-Za-z0-9_.:-]{1,64}$(?!\n)")]
Text = Annotated[str, Meta(max_length=256)]

StampNs = Annotated[
    int, Meta(ge=0, le=INT64_MAX, description="nanoseconds when measured (sim or vehicle time)")
]
Seq = Annotated[int, Meta(ge=0, le=INT64_MAX, description="per-publisher sequence number")]
Count = Annotated[int, Meta(ge=0, le=INT64_MAX)]

PositionM = Annotated[
    float, Meta(ge=-MAX_POSITION_M, le=MAX_POSITION_M, description="metres, local ENU")
]
DistanceM = Annotated[float, Meta(ge=0.0, le=MAX_POSITION_M, description="metres")]
StdM = Annotated[float, Meta(gt=0.0, le=MAX_POSITION_M, description="standard deviation, metres")]
StdOrZeroM = Annotated[float, Meta(ge=0.0, le=1e11, description="standard deviation, metres")]
"""A standard deviation that may be 0 (an exact value); 1e11 bounds the square root of any eigenvalue of a
2x2 block of a wire covariance (entries within +-1e20), so a summary of any valid track fits."""
AltitudeM = Annotated[float, Meta(ge=-1e4, le=1e5, description="metres")]

AngleRad = Annotated[
    float,
    Meta(ge=-math.pi, le=math.pi, description="radians, ENU from east counter-clockwise"),
]
ElevationRad = Annotated[
    float, Meta(ge=-math.pi / 2, le=math.pi / 2, description="radians, positive up")
]
AngleIncrementRad = Annotated[float, Meta(ge=-_TWO_PI, le=_TWO_PI, description="radians")]
StdRad = Annotated[float, Meta(gt=0.0, le=_TWO_PI, description="standard deviation, radians")]
RateRadS = Annotated[
    float, Meta(ge=-_TWO_PI, le=_TWO_PI, description="radians per second, counter-clockwise")
]

VelocityMps = Annotated[float, Meta(ge=-1e4, le=1e4, description="metres per second, ENU")]
SpeedMps = Annotated[float, Meta(ge=0.0, le=1e9, description="metres per second, ground speed")]
"""A speed (>= 0); 1e9 bounds the norm of any two state entries (within +-1e8), so any valid track's fits."""
AirspeedMps = Annotated[float, Meta(gt=0.0, le=1e3, description="metres per second")]
DurationS = Annotated[float, Meta(gt=0.0, le=3600.0, description="seconds")]
UptimeS = Annotated[float, Meta(ge=0.0, le=1e10, description="seconds")]
CommandAgeMs = Annotated[float, Meta(ge=-1e9, le=1e12, description="milliseconds")]
"""A command's age (vehicle time flown less its decision step's stamp), ms: finite, within about 30 years."""

LatDeg = Annotated[float, Meta(ge=-90.0, le=90.0, description="WGS84 latitude, degrees")]
LonDeg = Annotated[float, Meta(ge=-180.0, le=180.0, description="WGS84 longitude, degrees")]

StateValue = Annotated[float, Meta(ge=-MAX_POSITION_M, le=MAX_POSITION_M)]
CovarianceEntry = Annotated[float, Meta(ge=-1e20, le=1e20)]


#: ``|P[i, j] - P[j, i]| <= rtol * max(1, |P[i, i]|, |P[j, j]|)`` is accepted as symmetric.
COVARIANCE_SYMMETRY_RTOL = 1e-9


def _plainly_valid(values: Sequence[float], n: int) -> bool:
    """Finite, a non-negative diagonal and exactly symmetric (a quick test; False says nothing)."""
    rows = list(values)
    return (all(map(math.isfinite, rows)) and min(rows[:: n + 1]) >= 0.0
            and rows == [x for i in range(n) for x in rows[i::n]])


def check_covariance(values: Sequence[float], n: int, name: str) -> None:
    """Check a row-major ``n x n`` covariance: length, finite, diagonal >= 0, symmetric.

    Raises
    ------
    ProtocolError
        Naming ``name`` (and the entry's index) when a rule is broken.
    """
    if len(values) != n * n:
        raise ProtocolError(
            f"{name} has {len(values)} entries, expected {n * n} (row-major {n}x{n})",
            field=f"$.{name}",
        )
    if n and _plainly_valid(values, n):  # every covariance the daemon publishes; the loops below name the fault
        return
    for k, v in enumerate(values):
        if not math.isfinite(v):
            raise ProtocolError(f"{name}[{k}] is not finite ({v!r})", field=f"$.{name}[{k}]")
    for i in range(n):
        d = values[i * n + i]
        if d < 0.0:
            raise ProtocolError(
                f"{name}[{i * n + i}] (diagonal {i}) is negative ({d!r})",
                field=f"$.{name}[{i * n + i}]",
            )
    for i in range(n):
        for j in range(i + 1, n):
            a, b = values[i * n + j], values[j * n + i]
            scale = max(1.0, abs(values[i * n + i]), abs(values[j * n + j]))
            if abs(a - b) > COVARIANCE_SYMMETRY_RTOL * scale:
                raise ProtocolError(
                    f"{name} is not symmetric: entry ({i},{j}) = {a!r} but ({j},{i}) = {b!r}",
                    field=f"$.{name}[{i * n + j}]",
                )
