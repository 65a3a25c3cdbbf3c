"""The status's summary of a track: position, worst-axis 1-sigma and speed (no network)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gcs.daemon.track_summary import summarise_track, worst_axis_std
from protocols.codec import decode, encode
from protocols.messages import DaemonStatus, TrackEstimate, TrackSummary


def _track(state: tuple[float, ...], cov: np.ndarray, model: str = "cv2d", target_id: str = "t1") -> TrackEstimate:
    return TrackEstimate(target_id=target_id, seq=3, stamp_ns=5_000_000_000, model=model, state=state,
                         covariance=tuple(float(v) for v in cov.ravel()), contributing_vehicles=("uav1", "uav3"))


def test_a_diagonal_covariance_gives_the_root_of_its_larger_position_variance() -> None:
    summary = summarise_track(_track((100.123, -20.456, 3.0, 4.0), np.diag([9.0, 4.0, 400.0, 400.0])))
    assert summary == TrackSummary(target_id="t1", stamp_ns=5_000_000_000, x_m=100.12, y_m=-20.46,
                                   position_std_m=3.0, speed_mps=5.0, contributing_vehicles=("uav1", "uav3"))
    assert summarise_track(_track((0.0, 0.0, 0.0, 0.0), np.diag([4.0, 9.0, 1.0, 1.0]))).position_std_m == 3.0


def test_a_rotated_covariance_gives_its_major_axis() -> None:
    # diag(25, 4) turned by 30 degrees: P = R diag(25, 4) R^T, by hand with cos = sqrt(3)/2, sin = 1/2:
    # p_xx = 25 * 3/4 + 4 * 1/4 = 19.75, p_yy = 25 * 1/4 + 4 * 3/4 = 9.25, p_xy = (25 - 4) sqrt(3)/4.
    cov = np.eye(4)
    cov[:2, :2] = [[19.75, 21 * math.sqrt(3) / 4], [21 * math.sqrt(3) / 4, 9.25]]
    assert summarise_track(_track((0.0, 0.0, -6.0, 8.0), cov)).position_std_m == 5.0
    assert summarise_track(_track((0.0, 0.0, -6.0, 8.0), cov)).speed_mps == 10.0
    assert worst_axis_std(19.75, 21 * math.sqrt(3) / 4, 9.25) == pytest.approx(5.0, abs=1e-12)


def test_the_off_diagonal_counts_and_a_block_that_is_not_psd_is_clipped() -> None:
    assert worst_axis_std(1.0, 3.0, 1.0) == pytest.approx(2.0)  # eigenvalues 4 and -2
    assert worst_axis_std(0.0, 0.0, 0.0) == 0.0
    assert worst_axis_std(-1e-18, 0.0, -1e-18) == 0.0  # below zero by rounding only


def test_speed_needs_a_velocity_and_ca2d_takes_it_from_entries_2_and_3() -> None:
    ca = summarise_track(_track((1.0, 2.0, 0.3, 0.4, 50.0, 50.0), np.eye(6), model="ca2d"))
    assert ca.speed_mps == 0.5 and ca.position_std_m == 1.0
    assert summarise_track(_track((1.0, 2.0), np.diag([16.0, 1.0]), model="xy")).speed_mps is None
    assert summarise_track(_track((1.0, 2.0, 7.0), np.eye(3), model="xyz")).speed_mps is None
    with pytest.raises(ValueError, match="no horizontal position"):
        summarise_track(_track((1.0,), np.eye(1), model="x"))


def test_velocity_variance_does_not_enter_the_position_sigma() -> None:
    cov = np.diag([1.0, 1.0, 1e6, 1e6])
    cov[0, 2] = cov[2, 0] = 500.0
    assert summarise_track(_track((0.0, 0.0, 0.0, 0.0), cov)).position_std_m == 1.0


entries = st.floats(-1e20, 1e20, allow_nan=False)


@given(st.floats(0.0, 1e20), st.floats(0.0, 1e20), entries,
       st.lists(st.floats(-1e8, 1e8, allow_nan=False), min_size=4, max_size=4))
def test_any_valid_track_gives_a_summary_the_wire_accepts(p_xx, p_yy, p_xy, state) -> None:
    cov = np.diag([p_xx, p_yy, 1.0, 1.0])
    cov[0, 1] = cov[1, 0] = p_xy
    summary = summarise_track(_track(tuple(state), cov))
    eigen = np.linalg.eigvalsh(cov[:2, :2])[-1]
    assert summary.position_std_m == pytest.approx(math.sqrt(max(eigen, 0.0)), rel=1e-9, abs=0.005)
    status = DaemonStatus(stamp_ns=1, uptime_s=0.0, scenario="city", vehicles=(), tracks=(summary,))
    assert decode(*encode(status), DaemonStatus).tracks == (summary,)
