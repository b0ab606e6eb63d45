"""navigation/precision_landing.py: each of the seed's steps, each descent rule, and the
phase machine's outcomes (found, lost, timeout), without the simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from navigation.precision_landing import (
    Fail,
    Failure,
    LandingParams,
    LandingStrategy,
    LandNow,
    Measurement,
    Phase,
    Pose,
    PrecisionLander,
    ReachTo,
    Wait,
    aligned,
    attitude_ok,
    body_to_map,
    low_pass,
    search_pattern,
    truncate,
)

PAD = (5.0, 3.0, 0.0)
P = LandingParams()


def test_attitude_gate():
    assert attitude_ok(0.01, -0.02, 0.05)
    assert not attitude_ok(0.06, 0.0, 0.05)
    assert not attitude_ok(0.0, -0.06, 0.05)


def test_eq3_rotates_body_into_map():
    # heading north (yaw 90 deg): 1 m ahead is +y in the map, 1 m left is -x
    assert body_to_map([1.0, 0.0], math.pi / 2) == pytest.approx([0.0, 1.0], abs=1e-12)
    assert body_to_map([0.0, 1.0], math.pi / 2) == pytest.approx([-1.0, 0.0], abs=1e-12)


@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(-math.pi, math.pi))
def test_eq3_keeps_length_and_inverts(ex, ey, yaw):
    e = body_to_map([ex, ey], yaw)
    assert np.hypot(*e) == pytest.approx(math.hypot(ex, ey), abs=1e-12)
    assert body_to_map(e, -yaw) == pytest.approx([ex, ey], abs=1e-12)


def test_first_order_filter():
    y = low_pass(None, [1.0, 2.0], 0.5)
    assert y == pytest.approx([1.0, 2.0])
    assert low_pass(y, [3.0, 0.0], 0.5) == pytest.approx([2.0, 1.0])
    assert low_pass(y, [3.0, 0.0], 1.0) == pytest.approx([3.0, 0.0])


def test_truncation_to_centimetres_goes_towards_zero():
    assert truncate([0.079, -0.079, 0.07, 0.004], 0.01) == pytest.approx([0.07, -0.07, 0.07,
                                                                          0.0])
    assert truncate([0.0123], 0.0) == pytest.approx([0.0123])


def test_descent_needs_both_radius_and_velocity():
    assert aligned([0.01, 0.01], 0.05, P)
    assert not aligned([0.04, 0.0], 0.05, P)  # outside align_radius (0.04)
    assert not aligned([0.01, 0.0], 0.2, P)  # too fast


def test_search_pattern_rings():
    points = search_pattern((1.0, 2.0), 0.5, 2)
    assert len(points) == 17
    assert points[0] == pytest.approx([1.0, 2.0])
    assert max(np.abs(np.array(points) - [1.0, 2.0]).max(axis=1)) == pytest.approx(1.0)


def _lander(strategy=LandingStrategy.CAPTURE, **kw) -> PrecisionLander:
    lander = PrecisionLander(LandingParams(**kw), PAD, strategy, start_s=0.0)
    lander.start((PAD[0], PAD[1], 1.5))
    return lander


def _seen(lander, t, at, *, speed=0.0, busy=False, height=None, roll=0.0):
    """A frame from ``at`` (x, y, z) with the pad where it is, yaw 0."""
    offset = (PAD[0] - at[0], PAD[1] - at[1])
    h = at[2] if height is None else height
    pose = Pose(at, 0.0, roll, 0.0)
    return lander.on_frame(t, Measurement(offset, h), pose, at, speed, busy)


def test_off_centre_it_reaches_position_plus_error_at_the_same_altitude():
    lander = _lander(min_fresh_frames=1)
    cmd = _seen(lander, 0.1, (4.8, 3.1, 1.5))
    assert isinstance(cmd, ReachTo)
    assert cmd.position == pytest.approx((5.0, 3.0, 1.5))
    assert lander.phase is Phase.ALIGN


@pytest.mark.parametrize("strategy", list(LandingStrategy))
def test_the_step_truncates_the_error_to_centimetres_before_using_it(strategy):
    """Seed 003: the filtered error is truncated to centimetres, then the descent check,
    then the reach. The pad 0.0399 m east and 0.0299 m north: 5 cm away, outside the
    4 cm align radius; truncated, (0.03, 0.02) is 3.6 cm, inside, so the vehicle steps
    down, and the reach goes to the truncated offset, not the raw one."""
    lander = _lander(strategy, min_fresh_frames=1)
    at = (PAD[0] - 0.0399, PAD[1] - 0.0299, 1.5)
    assert not aligned([0.0399, 0.0299], 0.0, P), "the raw error must be outside the radius"
    cmd = _seen(lander, 0.1, at)
    assert lander.error == pytest.approx([0.03, 0.02], abs=1e-12)
    assert isinstance(cmd, ReachTo)
    assert cmd.position == pytest.approx((at[0] + 0.03, at[1] + 0.02, 1.5 - P.descent_step),
                                         abs=1e-12)
    assert lander.phase is Phase.DESCEND


def test_aligned_and_slow_it_steps_down():
    lander = _lander(min_fresh_frames=1)
    cmd = _seen(lander, 0.1, (5.01, 3.0, 1.5))
    assert isinstance(cmd, ReachTo)
    assert cmd.position[2] == pytest.approx(1.5 - P.descent_step)
    assert lander.phase is Phase.DESCEND


def test_aligned_but_fast_it_holds_altitude():
    lander = _lander(min_fresh_frames=1)
    cmd = _seen(lander, 0.1, (5.01, 3.0, 1.5), speed=0.5)
    assert isinstance(cmd, ReachTo) and cmd.position[2] == pytest.approx(1.5)


def test_below_the_minimum_altitude_it_lands():
    lander = _lander(min_fresh_frames=1)
    lander.reference_altitude = P.min_altitude + 0.5 * P.descent_step
    assert isinstance(_seen(lander, 0.1, (5.0, 3.0, 1.0)), LandNow)
    assert lander.phase is Phase.FINAL_LAND


def test_a_tilted_frame_is_discarded():
    lander = _lander(min_fresh_frames=1)
    assert isinstance(_seen(lander, 0.1, (4.5, 3.0, 1.5), roll=0.2), Wait)
    assert lander.filtered is None


def test_while_a_move_is_flown_only_the_filter_learns():
    lander = _lander(min_fresh_frames=1)
    assert isinstance(_seen(lander, 0.1, (4.5, 3.0, 1.5), busy=True), Wait)
    assert lander.filtered == pytest.approx([5.0, 3.0])


def test_capture_strategy_rejects_a_jump_and_a_wrong_height():
    lander = _lander(min_fresh_frames=1)
    _seen(lander, 0.1, (4.9, 3.0, 1.5))
    before = lander.filtered.copy()
    # a misread putting the pad 0.5 m away
    far = Measurement((0.6, 0.0), 1.5)
    assert isinstance(lander.on_frame(0.2, far, Pose((4.9, 3.0, 1.5), 0.0), (4.9, 3.0, 1.5),
                                      0.0, False), Wait)
    # a height that disagrees with the vehicle's by 1 m
    assert isinstance(_seen(lander, 0.3, (4.9, 3.0, 1.5), height=0.5), Wait)
    assert lander.filtered == pytest.approx(before)


def test_seed_strategy_filters_the_error_itself():
    lander = _lander(LandingStrategy.SEED)
    _seen(lander, 0.1, (4.8, 3.0, 1.5), busy=True)
    _seen(lander, 0.2, (4.9, 3.0, 1.5), busy=True)
    assert lander.filtered == pytest.approx([0.15, 0.0])  # 0.2, then halfway to 0.1


def test_found_after_searching():
    lander = _lander(min_fresh_frames=1)
    nothing = Pose((4.0, 3.0, 1.5), 0.0)
    first = lander.on_frame(0.0, None, nothing, nothing.position, 0.0, False)
    assert isinstance(first, Wait)  # looks where it is first
    cmd = lander.on_frame(P.lost_timeout_s + 0.1, None, nothing, nothing.position, 0.0, False)
    assert isinstance(cmd, ReachTo) and cmd.position[:2] == pytest.approx(PAD[:2])
    assert lander.phase is Phase.SEARCH
    assert isinstance(_seen(lander, 3.0, (4.9, 3.0, 1.5)), ReachTo)
    assert lander.phase is Phase.ALIGN


def test_not_found_after_the_search_timeout():
    lander = _lander(search_timeout_s=5.0)
    pose = Pose((4.0, 3.0, 1.5), 0.0)
    cmd = lander.on_frame(5.5, None, pose, pose.position, 0.0, False)
    assert isinstance(cmd, Fail) and cmd.failure is Failure.NOT_FOUND


def test_lost_during_descent_fails_without_retries():
    lander = _lander(min_fresh_frames=1, retries=0)
    _seen(lander, 0.1, (5.0, 3.0, 1.5))
    pose = Pose((5.0, 3.0, 1.2), 0.0)
    assert isinstance(lander.on_frame(0.5, None, pose, pose.position, 0.0, False), Wait)
    cmd = lander.on_frame(0.2 + P.lost_timeout_s, None, pose, pose.position, 0.0, False)
    assert isinstance(cmd, Fail) and cmd.failure is Failure.LOST


def test_lost_with_a_retry_climbs_back_to_search():
    lander = _lander(min_fresh_frames=1, retries=1)
    _seen(lander, 0.1, (5.0, 3.0, 1.5))
    pose = Pose((5.0, 3.0, 1.2), 0.0)
    cmd = lander.on_frame(0.2 + P.lost_timeout_s, None, pose, pose.position, 0.0, False)
    assert isinstance(cmd, ReachTo) and cmd.position[2] == pytest.approx(P.search_altitude)
    assert lander.phase is Phase.SEARCH and lander.retries_left == 0


def test_timeout():
    lander = _lander(timeout_s=10.0)
    cmd = _seen(lander, 10.5, (5.0, 3.0, 1.5))
    assert isinstance(cmd, Fail) and cmd.failure is Failure.TIMEOUT


def test_bad_parameters_name_the_key():
    with pytest.raises(ValueError, match="filter_gain"):
        LandingParams(filter_gain=0.0)
    with pytest.raises(ValueError, match="search_altitude"):
        LandingParams(search_altitude=0.5, min_altitude=0.8)
