"""The filter's API refuses misuse with a message that says what was wrong, and takes the prior once."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.filters.estimate import CA2D, CT2D, CV2D, StateLayout, ns_from_s
from gcs.core.filters.uif import GaussianEstimate, InformationContribution, UnscentedInformationFilter
from gcs.core.models.motion import constant_acceleration, constant_velocity
from gcs.core.models.sensor import SensorModel

UIF = UnscentedInformationFilter(constant_velocity(1.96))
SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
VEHICLE = np.array([1200.0, 1300.0, 200.0])
PRIOR = GaussianEstimate(np.array([1500.0, 1450.0, 5.0, -2.0]), np.diag([400.0, 300.0, 25.0, 25.0]), 0)


def _measured(estimate: GaussianEstimate) -> np.ndarray:
    return SENSOR.measure(estimate.mean[:2] + [12.0, -7.0], VEHICLE)


def test_a_float_stamp_is_refused_with_the_conversion_not_read_as_nanoseconds() -> None:
    with pytest.raises(TypeError, match=r"integer number of nanoseconds, got float 1\.0.*ns_from_s\(1\.0\) = "
                                        r"1000000000"):
        UIF.predict(PRIOR, 1.0)
    with pytest.raises(TypeError, match="stamp_ns must be an integer"):
        GaussianEstimate(np.zeros(4), np.eye(4), 0.5)
    with pytest.raises(TypeError, match="got bool"):
        UIF.predict(PRIOR, True)
    one_second = UIF.predict(PRIOR, ns_from_s(1.0))
    assert one_second.stamp_ns == 1_000_000_000
    np.testing.assert_allclose(one_second.mean[:2], PRIOR.mean[:2] + PRIOR.mean[2:])  # F x over 1 s: p + v
    assert UIF.predict(PRIOR, np.int64(1_000_000_000)).stamp_ns == 1_000_000_000  # numpy integers are integers


def test_the_estimate_names_its_state_layout() -> None:
    assert PRIOR.layout is CV2D and PRIOR.layout.components == ("x_m", "y_m", "vx_mps", "vy_mps")
    assert PRIOR.layout.index("vy_mps") == 3 and PRIOR.velocity.tolist() == [5.0, -2.0]
    assert GaussianEstimate(np.zeros(5), np.eye(5), 0).layout is CT2D
    assert GaussianEstimate(np.zeros(6), np.eye(6), 0).layout is CA2D
    with pytest.raises(ValueError, match="cv2d has no component 'omega_rad_s'"):
        CV2D.index("omega_rad_s")
    with pytest.raises(ValueError, match="no state layout for a 3-dimensional state"):
        GaussianEstimate(np.zeros(3), np.eye(3), 0)
    own = StateLayout("xyz", ("x_m", "y_m", "z_m"))
    assert GaussianEstimate(np.zeros(3), np.eye(3), 0, layout=own).layout is own
    with pytest.raises(ValueError, match="does not describe a 4-dimensional state"):
        GaussianEstimate(np.zeros(4), np.eye(4), 0, layout=CA2D)
    predicted = UIF.predict(PRIOR, 10**9)
    assert predicted.layout is CV2D and UIF.update(UIF.contribution(predicted, SENSOR, _measured(predicted),
                                                                    VEHICLE)).layout is CV2D


@pytest.mark.parametrize("mean, cov, match", [
    (np.zeros(4), np.eye(3), r"cov must have shape \(4, 4\) for a mean of shape \(4,\), got \(3, 3\)"),
    (np.zeros((5, 4)), np.eye(4), r"cov must have shape \(5, 4, 4\)"),
    (np.float64(1.0), np.eye(1), "got a scalar"),
])
def test_shapes_that_do_not_match_are_refused(mean, cov, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        GaussianEstimate(mean, cov, 0)


def test_lists_are_taken_as_float64_and_nonsense_is_refused() -> None:
    estimate = GaussianEstimate([1.0, 2, 3, 4], np.eye(4, dtype=int).tolist(), 0)
    assert estimate.mean.dtype == estimate.cov.dtype == np.float64
    with pytest.raises(TypeError, match="mean must be an array of real numbers"):
        GaussianEstimate(["a", "b", "c", "d"], np.eye(4), 0)


def test_the_motion_model_and_the_estimate_must_have_the_same_state() -> None:
    six = GaussianEstimate(np.zeros(6), np.eye(6), 0)
    with pytest.raises(ValueError, match="the cv2d motion model predicts 4-dimensional states, the estimate is ca2d"):
        UIF.predict(six, 10**9)
    assert UnscentedInformationFilter(constant_acceleration(0.1)).predict(six, 10**9).dim == 6
    with pytest.raises(TypeError, match="estimate must be a GaussianEstimate, got tuple"):
        UIF.predict((np.zeros(4), np.eye(4), 0), 10**9)


@pytest.mark.parametrize("z, xyz, cov, match", [
    ([1000.0, 0.1], VEHICLE, None, r"z must have shape \(\.\.\., 3\) for a 3-component sensor, got \(2,\)"),
    ([1000.0, 0.1, 0.2], VEHICLE[:2], None, r"vehicle_xyz must have shape \(\.\.\., 3\)"),
    (np.ones((2, 3)), np.ones((3, 3)), None, "do not broadcast"),
    ([1000.0, 0.1, 0.2], VEHICLE, np.eye(2), r"vehicle_cov must have shape \(\) .* or \(3, 3\)"),
])
def test_measurements_of_the_wrong_shape_are_refused(z, xyz, cov, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        UIF.contribution(PRIOR, SENSOR, z, xyz, cov)


def test_contribution_needs_an_estimate_and_a_sensor() -> None:
    with pytest.raises(TypeError, match="prior must be a GaussianEstimate"):
        UIF.contribution(PRIOR.mean, SENSOR, _measured(PRIOR), VEHICLE)
    with pytest.raises(TypeError, match="sensor must be a SensorModel"):
        UIF.contribution(PRIOR, "range_bearing", _measured(PRIOR), VEHICLE)


def test_a_contribution_knows_its_prior_so_update_needs_it_once() -> None:
    contribution = UIF.contribution(PRIOR, SENSOR, _measured(PRIOR), VEHICLE)
    assert contribution.prior is PRIOR
    once = UIF.update([contribution])
    twice = UIF.update(PRIOR, [contribution])
    single = UIF.update(contribution)
    np.testing.assert_array_equal(once.mean, twice.mean)
    np.testing.assert_array_equal(single.cov, twice.cov)
    assert np.trace(once.cov[:2, :2]) < np.trace(PRIOR.cov[:2, :2])  # a detection narrows the position


def test_update_refuses_contributions_made_against_another_prior() -> None:
    predicted = UIF.predict(PRIOR, 10**9)
    stale = UIF.contribution(PRIOR, SENSOR, _measured(PRIOR), VEHICLE)
    with pytest.raises(ValueError, match=r"contribution 0 was computed against another prior \(stamp 0 ns\) than "
                                         r"the one given \(stamp 1000000000 ns\)"):
        UIF.update(predicted, [stale])
    fresh = UIF.contribution(predicted, SENSOR, _measured(predicted), VEHICLE)
    with pytest.raises(ValueError, match="different priors"):
        UIF.update([stale, fresh])
    equal_copy = GaussianEstimate(PRIOR.mean.copy(), PRIOR.cov.copy(), PRIOR.stamp_ns)
    np.testing.assert_array_equal(UIF.update(equal_copy, [stale]).mean, UIF.update([stale]).mean)


def test_an_iterated_update_says_which_point_it_linearised_about() -> None:
    prior = UIF.predict(PRIOR, 10**9)
    z = _measured(prior)
    posterior = UIF.update(UIF.contribution(prior, SENSOR, z, VEHICLE))
    about_posterior = UIF.contribution(posterior, SENSOR, z, VEHICLE)
    with pytest.raises(ValueError, match="computed against another prior"):
        UIF.update(prior, [about_posterior])
    with pytest.raises(ValueError, match="computed against another estimate than point"):
        about_posterior.linearised_about(prior, prior)
    relinearised = UIF.update(prior, [about_posterior.linearised_about(posterior, prior)])
    assert relinearised.stamp_ns == prior.stamp_ns
    assert np.trace(relinearised.cov[:2, :2]) < np.trace(prior.cov[:2, :2])
    # Fused into the prior, not into the posterior: the prior's information plus this one's, once.
    twice = UIF.update(about_posterior)
    assert np.trace(relinearised.cov[:2, :2]) > np.trace(twice.cov[:2, :2])


def test_update_says_what_it_cannot_fuse() -> None:
    with pytest.raises(ValueError, match=r"needs contributions made by contribution\(\)"):
        UIF.update([])
    bare = InformationContribution(np.zeros(2), np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"call update\(prior, contributions\)"):
        UIF.update([bare])
    assert UIF.update(PRIOR, [bare]).mean.tolist() == PRIOR.mean.tolist()  # no information: the prior's mean
    assert UIF.update(PRIOR, []) is PRIOR
    with pytest.raises(TypeError, match="contributions must be InformationContribution"):
        UIF.update(PRIOR, [np.zeros(2)])


def test_the_daemons_filter_is_the_documented_default_the_second_order_form() -> None:
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario
    from gcs.engine.tracker_factory import scenario_planner, tracker_config

    scenario = load_scenario("wang2012_urban")
    config = tracker_config(scenario, build_world(scenario), scenario_planner(scenario))
    assert UnscentedInformationFilter(constant_velocity(1.0)).second_order is True
    assert config.uif.second_order is True


def test_the_documented_example_runs_and_narrows_the_estimate() -> None:
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "estimation.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", page, re.S)
    (code,) = [block for block in blocks if "UnscentedInformationFilter" in block]
    scope: dict = {}
    exec(compile(code, "docs/estimation.md", "exec"), scope)  # noqa: S102 - the documentation's own example
    prior, posterior = scope["prior"], scope["posterior"]
    assert prior.stamp_ns == 1_000_000_000 and posterior.layout is CV2D
    assert np.linalg.det(posterior.cov[:2, :2]) < 0.5 * np.linalg.det(prior.cov[:2, :2])
