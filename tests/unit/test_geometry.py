"""wrap_angle and WGS84 <-> ENU, against known points and as properties."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gcs.core.geometry import WGS84_A, WGS84_F, LocalFrame, ecef_to_geodetic, geodetic_to_ecef, wrap_angle

finite_angles = st.floats(min_value=-1e4, max_value=1e4, allow_nan=False)


@pytest.mark.parametrize(
    ("angle", "expected"),
    [(0.0, 0.0), (math.pi, math.pi), (-math.pi, math.pi), (3 * math.pi, math.pi),
     (1.5 * math.pi, -0.5 * math.pi), (-1.5 * math.pi, 0.5 * math.pi), (2 * math.pi + 0.1, 0.1)],
)
def test_wrap_angle_known_values(angle: float, expected: float) -> None:
    assert wrap_angle(angle) == pytest.approx(expected, abs=1e-12)


@given(finite_angles)
def test_wrap_angle_is_in_half_open_interval_and_equivalent(angle: float) -> None:
    wrapped = wrap_angle(angle)
    assert -math.pi < wrapped <= math.pi
    assert math.sin(wrapped) == pytest.approx(math.sin(angle), abs=1e-9)
    assert math.cos(wrapped) == pytest.approx(math.cos(angle), abs=1e-9)


def test_wrap_angle_keeps_array_shape() -> None:
    angles = np.array([[0.0, 4.0], [-4.0, 7.0]])
    wrapped = wrap_angle(angles)
    assert isinstance(wrapped, np.ndarray) and wrapped.shape == (2, 2)
    np.testing.assert_allclose(wrapped, [[0.0, 4.0 - 2 * np.pi], [-4.0 + 2 * np.pi, 7.0 - 2 * np.pi]])


def test_ecef_of_known_points() -> None:
    b = WGS84_A * (1 - WGS84_F)
    np.testing.assert_allclose(geodetic_to_ecef(0.0, 0.0, 0.0), [WGS84_A, 0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(geodetic_to_ecef(0.0, 90.0, 100.0), [0.0, WGS84_A + 100.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(geodetic_to_ecef(90.0, 0.0, 0.0), [0.0, 0.0, b], atol=1e-6)
    np.testing.assert_allclose(geodetic_to_ecef(-90.0, 0.0, 10.0), [0.0, 0.0, -b - 10.0], atol=1e-6)


def test_enu_of_a_point_one_degree_east_on_the_equator() -> None:
    frame = LocalFrame(0.0, 0.0, 0.0)
    one = math.radians(1.0)
    # ECEF of (0, 1 deg, 0) is a (cos 1deg, sin 1deg, 0); at the origin east = +Y, up = +X.
    np.testing.assert_allclose(
        frame.to_enu(0.0, 1.0, 0.0), [WGS84_A * math.sin(one), 0.0, WGS84_A * (math.cos(one) - 1.0)], atol=1e-6
    )


def test_enu_of_a_point_one_degree_north_on_the_meridian() -> None:
    frame = LocalFrame(0.0, 0.0, 0.0)
    phi = math.radians(1.0)
    e2 = WGS84_F * (2 - WGS84_F)
    n = WGS84_A / math.sqrt(1 - e2 * math.sin(phi) ** 2)
    # Known value: the chord north is N (1 - e^2) sin(1 deg) = 110568.8 m (WGS84).
    north = n * (1 - e2) * math.sin(phi)
    assert north == pytest.approx(110568.8, abs=0.1)
    np.testing.assert_allclose(frame.to_enu(1.0, 0.0, 0.0), [0.0, north, n * math.cos(phi) - WGS84_A], atol=1e-6)


def test_origin_maps_to_zero_and_axes_point_the_right_way() -> None:
    frame = LocalFrame(28.22, 112.99, 50.0)
    np.testing.assert_allclose(frame.to_enu(28.22, 112.99, 50.0), [0.0, 0.0, 0.0], atol=1e-6)
    east = frame.to_enu(28.22, 112.9901, 50.0)
    north = frame.to_enu(28.2201, 112.99, 50.0)
    up = frame.to_enu(28.22, 112.99, 150.0)
    assert east[0] > 9.0 and abs(east[1]) < 1e-3
    assert north[1] > 11.0 and abs(north[0]) < 1e-6
    np.testing.assert_allclose(up, [0.0, 0.0, 100.0], atol=1e-6)


@given(
    st.floats(-89.0, 89.0), st.floats(-180.0, 180.0), st.floats(-100.0, 3000.0),
    st.floats(-50_000.0, 50_000.0), st.floats(-50_000.0, 50_000.0), st.floats(-500.0, 5000.0),
)
def test_enu_geodetic_round_trip(lat0: float, lon0: float, h0: float, e: float, n: float, u: float) -> None:
    frame = LocalFrame(lat0, lon0, h0)
    lat, lon, h = frame.to_geodetic([e, n, u])
    np.testing.assert_allclose(frame.to_enu(lat, lon, h), [e, n, u], atol=1e-4)


@given(st.floats(-89.9, 89.9), st.floats(-179.9, 179.9), st.floats(-400.0, 30_000.0))
def test_ecef_geodetic_round_trip(lat: float, lon: float, h: float) -> None:
    lat2, lon2, h2 = ecef_to_geodetic(geodetic_to_ecef(lat, lon, h))
    assert lat2 == pytest.approx(lat, abs=1e-9)
    assert lon2 == pytest.approx(lon, abs=1e-9)
    assert h2 == pytest.approx(h, abs=1e-4)


def test_bad_origin_is_rejected_with_the_field_named() -> None:
    with pytest.raises(ValueError, match="lat_deg"):
        LocalFrame(91.0, 0.0)
    with pytest.raises(ValueError, match="lon_deg"):
        LocalFrame(0.0, float("nan"))
