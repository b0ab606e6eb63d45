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
    level_offset,
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


def _seen(lander, t, at, *, speed=0.0, busy=False, height=None, roll=0.0, captured=None):
    """A frame from ``at`` (x, y, z) with the pad where it is, yaw 0, exposed at
    ``captured`` (None: ``t``)."""
    offset = (PAD[0] - at[0], PAD[1] - at[1])
    h = at[2] if height is None else height
    pose = Pose(at, 0.0, roll, 0.0)
    return lander.on_frame(t, Measurement(offset, h), pose, at, speed, busy,
                           captured_s=captured)


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


# -- edges of each rule (found by mutation testing: each test fails on a changed comparison,
# -- a dropped term or a skipped reset in navigation/precision_landing.py) ----------------

_BAD_AND_GOOD = {
    # key: (values out of range, values at the edge of the range)
    "max_tilt": ([0.0, math.pi / 2], [1e-6, math.pi / 2 - 1e-6]),
    "filter_gain": ([0.0, 1.0 + 1e-9], [1e-6, 1.0]),
    "resolution": ([-1e-9, 1.0], [0.0, 0.999]),
    "align_radius": ([0.0], [1e-9]),
    "max_align_speed": ([0.0], [1e-9]),
    "descent_step": ([0.0], [1e-9]),
    "min_altitude": ([0.0], [1e-9]),
    "search_spacing": ([0.0], [1e-9]),
    "search_rings": ([-1], [0]),
    "search_detour": ([-1e-9], [0.0]),
    "search_timeout_s": ([0.0], [1e-9]),
    "lost_timeout_s": ([0.0], [1e-9]),
    "retries": ([-1], [0]),
    "timeout_s": ([0.0], [1e-9]),
    "outlier_distance": ([0.0], [1e-9]),
    "height_tolerance": ([0.0], [1e-9]),
    "max_rejections": ([0], [1]),
    "min_fresh_frames": ([0], [1]),
}


@pytest.mark.parametrize("key", sorted(_BAD_AND_GOOD))
def test_each_parameter_is_refused_just_outside_its_range_and_taken_at_its_edge(key):
    bad, good = _BAD_AND_GOOD[key]
    for value in bad:
        with pytest.raises(ValueError, match=rf"out of range: {key} \("):
            LandingParams(**{key: value})
    for value in good:
        assert getattr(LandingParams(**{key: value}), key) == value


def test_the_search_altitude_may_equal_the_minimum_and_the_error_names_every_bad_key():
    assert LandingParams(search_altitude=0.8, min_altitude=0.8).search_altitude == 0.8
    with pytest.raises(ValueError) as error:
        LandingParams(align_radius=0.0, retries=-1, search_altitude=0.7, min_altitude=0.8)
    assert str(error.value) == ("LandingParams: out of range: align_radius, search_altitude, "
                                "retries (search_altitude must be >= min_altitude)")


def test_the_gates_take_their_limits_themselves():
    assert attitude_ok(0.05, -0.05, 0.05), "a tilt of exactly max_tilt is level enough"
    assert attitude_ok(-0.05, 0.05, 0.05)
    assert not aligned([0.01, 0.0], P.max_align_speed, P), "exactly max_align_speed is fast"


def test_helpers_take_column_vectors_and_give_float_arrays():
    """A marker offset may come as a (2, 1) column (OpenCV's tvec); integers are metres."""
    assert body_to_map(np.array([[1.0], [0.0]]), math.pi / 2) == pytest.approx([0.0, 1.0])
    assert body_to_map(np.array([[1.0], [0.0]]), 0.0).shape == (2,)
    first = low_pass(None, [1, 2], 0.5)
    assert first.dtype == np.float64 and first.tolist() == [1.0, 2.0]
    assert low_pass(np.array([1.0, 2.0]), [2, 4], 0.5).tolist() == [1.5, 3.0]
    for resolution in (0.0, 0.01):
        kept = truncate([1, -2], resolution)
        assert kept.dtype == np.float64 and kept.tolist() == [1.0, -2.0]
    points = search_pattern(np.array([[1], [2]]), 0.5, 1)
    assert all(p.shape == (2,) and p.dtype == np.float64 for p in points)


def test_the_search_spiral_goes_round_anticlockwise_ring_by_ring():
    points = search_pattern((1.0, 2.0), 0.5, 2)
    expected = [(1.0, 2.0)] + [
        (1.0 + dx * r, 2.0 + dy * r)
        for r in (0.5, 1.0)
        for dx, dy in ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))
    ]
    assert np.array(points) == pytest.approx(np.array(expected))


RAISED_PAD = (5.0, 3.0, 0.5)  # a pad on a 0.5 m platform


def test_on_a_raised_pad_heights_count_from_the_pad():
    lander = PrecisionLander(LandingParams(min_fresh_frames=1, height_tolerance=0.25),
                             RAISED_PAD, LandingStrategy.CAPTURE, start_s=0.0)
    lander.start((5.0, 3.0, 2.0))
    assert lander.reference_altitude == pytest.approx(1.5)
    at = (5.0, 3.0, 1.5)  # 1.0 m above the pad
    pose = Pose(at, 0.0)
    # a PnP height exactly height_tolerance off is still believed; a bit more is not
    cmd = lander.on_frame(0.1, Measurement((0.0, 0.0), 1.25), pose, at, 0.0, False)
    assert isinstance(cmd, ReachTo)
    assert cmd.position[2] == pytest.approx(0.5 + 1.5 - lander.params.descent_step)
    assert lander.on_frame(0.2, Measurement((0.0, 0.0), 1.26), pose, at, 0.0, False) \
        == Wait("outlier dropped")


def test_the_step_reaching_exactly_min_altitude_still_descends_by_reach():
    lander = _lander(min_fresh_frames=1, min_altitude=0.75, descent_step=0.25)
    lander.reference_altitude = 1.0
    cmd = _seen(lander, 0.1, (5.0, 3.0, 1.0))
    assert cmd == ReachTo((5.0, 3.0, 0.75)) and lander.phase is Phase.DESCEND
    assert isinstance(_seen(lander, 0.2, (5.0, 3.0, 0.75)), LandNow)


def test_capture_needs_min_fresh_frames_after_each_move():
    lander = _lander()  # min_fresh_frames 2
    at = (4.9, 3.0, 1.5)
    assert _seen(lander, 0.1, at) == Wait("a move is being flown"), "one fresh frame"
    assert isinstance(_seen(lander, 0.2, at), ReachTo), "two fresh frames"
    assert _seen(lander, 0.3, at, busy=True) == Wait("a move is being flown")
    assert _seen(lander, 0.4, at) == Wait("a move is being flown"), "counting starts over"
    assert isinstance(_seen(lander, 0.5, at), ReachTo)


def test_the_seed_strategy_waits_too_while_a_move_is_flown():
    lander = _lander(LandingStrategy.SEED)
    assert _seen(lander, 0.1, (4.8, 3.0, 1.5), busy=True) == Wait("a move is being flown")


def test_capture_filters_consecutive_pad_estimates():
    lander = _lander(min_fresh_frames=1)
    pose_at = (4.5, 3.0, 1.5)
    pose = Pose(pose_at, 0.0)
    lander.on_frame(0.1, Measurement((0.5, 0.0), 1.5), pose, pose_at, 0.0, True)  # (5.0, 3.0)
    lander.on_frame(0.2, Measurement((0.7, 0.0), 1.5), pose, pose_at, 0.0, True)  # (5.2, 3.0)
    assert lander.filtered == pytest.approx([5.1, 3.0]), "halfway (filter_gain 0.5)"


def test_an_estimate_exactly_outlier_distance_away_is_taken():
    lander = _lander(min_fresh_frames=1)
    pose_at = (4.5, 3.0, 1.5)
    pose = Pose(pose_at, 0.0)
    lander.on_frame(0.1, Measurement((0.5, 0.0), 1.5), pose, pose_at, 0.0, True)  # (5.0, 3.0)
    lander.on_frame(0.2, Measurement((0.75, 0.0), 1.5), pose, pose_at, 0.0, True)  # 0.25 m
    assert lander.filtered == pytest.approx([5.125, 3.0])


def test_after_max_rejections_outliers_in_a_row_the_filter_restarts_from_the_data():
    """The first fix was a misread: the pad is 0.5 m further east. Five frames are dropped,
    the sixth (max_rejections) restarts the filter there; a good frame resets the count."""
    lander = _lander(min_fresh_frames=1)
    pose_at = (4.5, 3.0, 1.5)
    pose = Pose(pose_at, 0.0)

    def frame(t, offset_x):
        return lander.on_frame(t, Measurement((offset_x, 0.0), 1.5), pose, pose_at, 0.0, True)

    frame(0.0, 0.5)  # filtered (5.0, 3.0)
    for k in range(P.max_rejections - 1):
        assert frame(0.1 + 0.1 * k, 1.0) == Wait("outlier dropped")
    assert lander.filtered == pytest.approx([5.0, 3.0])
    frame(1.0, 1.0)
    assert lander.filtered == pytest.approx([5.5, 3.0]), "restarted from the data"
    for k in range(P.max_rejections - 1):  # a new run of outliers counts from zero again
        assert frame(1.1 + 0.1 * k, 0.0) == Wait("outlier dropped")
    assert lander.filtered == pytest.approx([5.5, 3.0])


def test_each_timeout_is_strict_and_counts_from_the_start_time():
    """A landing started at t = 100 s: the limits are measured from then, and a time
    exactly at a limit is still within it."""
    params = LandingParams(min_fresh_frames=1, lost_timeout_s=2.0, search_timeout_s=30.0,
                           timeout_s=120.0, retries=0)
    nothing = Pose((4.0, 3.0, 1.5), 0.0)

    def lander_at_100():
        lander = PrecisionLander(params, PAD, LandingStrategy.CAPTURE, start_s=100.0)
        lander.start(nothing.position)
        return lander

    def blind(lander, t, busy=False):
        return lander.on_frame(t, None, nothing, nothing.position, 0.0, busy)

    # looking where it is until lost_timeout_s, then searching
    lander = lander_at_100()
    assert blind(lander, 101.5) == Wait("looking for the marker where we are")
    assert isinstance(blind(lander, 102.0), ReachTo), "exactly lost_timeout_s: search"
    # the search gives up after search_timeout_s, not at it
    assert isinstance(blind(lander, 130.0), ReachTo)
    cmd = blind(lander, 130.5)
    assert isinstance(cmd, Fail) and cmd.failure is Failure.NOT_FOUND
    assert "no marker within 30 s of searching" in cmd.message
    # the whole landing: timeout_s
    lander = lander_at_100()
    assert isinstance(_seen(lander, 220.0, (4.9, 3.0, 1.5)), ReachTo)
    cmd = _seen(lander, 220.5, (4.9, 3.0, 1.5))
    assert isinstance(cmd, Fail) and cmd.failure is Failure.TIMEOUT and "120 s" in cmd.message
    # lost: more than lost_timeout_s since the marker was last seen
    lander = lander_at_100()
    assert isinstance(_seen(lander, 100.5, (5.0, 3.0, 1.5)), ReachTo)  # aligned: a step down
    assert blind(lander, 102.5) == Wait("marker not in this frame"), "exactly 2 s: not lost"
    cmd = blind(lander, 102.6)
    assert isinstance(cmd, Fail) and cmd.failure is Failure.LOST
    assert "2 s" in cmd.message and f"{1.5 - P.descent_step:.2f} m" in cmd.message


def test_a_tilted_frame_waits_for_the_attitude_gate():
    lander = _lander(min_fresh_frames=1)
    assert _seen(lander, 0.1, (4.5, 3.0, 1.5), roll=0.2) == Wait("attitude gate: not level")


def test_while_searching_a_running_move_is_waited_for():
    lander = _lander(min_fresh_frames=1)
    nothing = Pose((4.0, 3.0, 1.5), 0.0)
    t = P.lost_timeout_s + 0.1
    assert lander.on_frame(t, None, nothing, nothing.position, 0.0, True) == Wait("searching")


def test_lost_with_a_retry_while_a_move_is_flown_waits_then_searches_afresh():
    lander = _lander(min_fresh_frames=1, retries=1)
    _seen(lander, 0.1, (5.0, 3.0, 1.5))
    pose = Pose((5.0, 3.0, 1.2), 0.0)
    t = 0.2 + P.lost_timeout_s
    assert lander.on_frame(t, None, pose, pose.position, 0.0, True) == Wait("searching")
    assert lander.phase is Phase.SEARCH and lander.filtered is None
    # seen again: the filter starts from this measurement, not from before the loss
    cmd = _seen(lander, t + 0.1, (4.8, 3.0, 1.5))
    assert isinstance(cmd, ReachTo) and lander.filtered == pytest.approx([5.0, 3.0])


def test_the_seed_strategy_searches_only_over_the_pad_and_never_retries():
    lander = _lander(LandingStrategy.SEED, min_fresh_frames=1, retries=2)
    assert lander.retries_left == 0
    nothing = Pose((4.0, 3.0, 1.5), 0.0)
    t = P.lost_timeout_s + 0.1
    first = lander.on_frame(t, None, nothing, nothing.position, 0.0, False)
    assert isinstance(first, ReachTo) and first.position[:2] == pytest.approx(PAD[:2])
    assert lander.on_frame(t + 0.1, None, nothing, nothing.position, 0.0, False) \
        == Wait("at the pad's position, waiting for the marker")
    _seen(lander, t + 0.2, (4.9, 3.0, 1.5))
    cmd = lander.on_frame(t + 0.3 + P.lost_timeout_s, None, nothing, nothing.position, 0.0,
                          False)
    assert isinstance(cmd, Fail) and cmd.failure is Failure.LOST


def test_capture_goes_round_the_whole_spiral_then_starts_again():
    lander = _lander(min_fresh_frames=1, search_rings=1, search_spacing=0.5)
    nothing = Pose((4.0, 3.0, 1.5), 0.0)
    t = P.lost_timeout_s + 0.1
    targets = []
    for k in range(11):  # the centre, 8 points of one ring, then the centre and east again
        cmd = lander.on_frame(t + 0.1 * k, None, nothing, nothing.position, 0.0, False)
        assert isinstance(cmd, ReachTo)
        targets.append(cmd.position[:2])
    spiral = search_pattern(PAD[:2], 0.5, 1)
    assert np.array(targets) == pytest.approx(np.array(spiral + spiral[:2]))


# -- with the camera's latency (issue 21) ---------------------------------------------------
def _rotation(roll: float, pitch: float) -> np.ndarray:
    """Body -> level frame: R_y(pitch) R_x(roll), the ZYX attitude without its yaw."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    return ry @ rx


def _camera_sees(level: tuple[float, float, float], roll: float, pitch: float) -> Measurement:
    """What the down camera measures of a point ``level`` (x, y, z) [m] from it in the
    level frame: the point in the body frame, its height along the optical axis (-z)."""
    b = _rotation(roll, pitch).T @ np.array(level)
    return Measurement((float(b[0]), float(b[1])), float(-b[2]))


def test_a_pitched_camera_sees_the_pad_ahead_and_levelling_puts_it_back_below():
    """Right over the pad at 1 m, nose down by 0.05 rad (inside the 0.06 rad gate): the
    camera looks back, so the pad shows 5 cm ahead. Levelled, it is below again."""
    m = _camera_sees((0.0, 0.0, -1.0), 0.0, 0.05)
    assert m.offset_body == pytest.approx((math.sin(0.05), 0.0), abs=1e-12)
    assert level_offset(m.offset_body, m.height, 0.0, 0.05) == pytest.approx([0.0, 0.0],
                                                                              abs=1e-12)
    rolled = _camera_sees((0.0, 0.0, -1.0), 0.05, 0.0)  # left side up: looks left
    assert rolled.offset_body[1] == pytest.approx(-math.sin(0.05), abs=1e-12), "pad right"
    assert level_offset(rolled.offset_body, rolled.height, 0.05, 0.0) == pytest.approx(
        [0.0, 0.0], abs=1e-12)


@given(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(0.3, 3.0),
       st.floats(-0.3, 0.3), st.floats(-0.3, 0.3))
def test_levelling_inverts_the_cameras_tilt(x, y, height, roll, pitch):
    m = _camera_sees((x, y, -height), roll, pitch)
    assert level_offset(m.offset_body, m.height, roll, pitch) == pytest.approx([x, y],
                                                                               abs=1e-9)


@pytest.mark.parametrize("roll, pitch", [(0.05, 0.0), (0.0, -0.05), (-0.04, 0.04)])
def test_capture_levels_each_frame_with_the_attitude_at_its_capture(roll, pitch):
    """Over the pad at 1 m, tilted within the gate at the exposure (the pose paired with
    the frame): CAPTURE finds the pad below and steps down without a correction; the
    seed, which only gates the tilt, takes it for 4-7 cm off and corrects instead."""
    at = (PAD[0], PAD[1], 1.0)
    m = _camera_sees((0.0, 0.0, -1.0), roll, pitch)
    pose = Pose(at, 0.0, roll, pitch)
    ours = _lander(min_fresh_frames=1)
    cmd = ours.on_frame(0.1, m, pose, at, 0.0, False)
    assert ours.filtered == pytest.approx(PAD[:2], abs=1e-9)
    assert ours.phase is Phase.DESCEND and isinstance(cmd, ReachTo)
    assert cmd.position[:2] == pytest.approx(at[:2], abs=1e-9)
    seed = _lander(LandingStrategy.SEED, min_fresh_frames=1)
    seed.on_frame(0.1, m, pose, at, 0.0, False)
    assert float(np.hypot(*seed.error)) >= 0.04 and seed.phase is Phase.ALIGN


def test_capture_decides_only_on_frames_exposed_after_the_move_ended():
    """The camera publishes 50 ms after the exposure, 12 frames a second. The move ends
    at 1.0 s; the frame read at 1.03 s was exposed at 0.98 s, still during the move, so
    it is no fresh frame: the decision waits for two frames exposed from 1.0 s on."""
    lander = _lander()  # min_fresh_frames 2
    at = (4.9, 3.0, 1.5)
    _seen(lander, 0.1, at, captured=0.05)
    assert isinstance(_seen(lander, 0.2, at, captured=0.15), ReachTo)
    assert _seen(lander, 0.6, at, busy=True, captured=0.55) == Wait("a move is being flown")
    lander.move_ended(1.0)
    assert _seen(lander, 1.03, at, captured=0.98) == Wait("a move is being flown")
    assert _seen(lander, 1.11, at, captured=1.06) == Wait("a move is being flown")
    assert isinstance(_seen(lander, 1.19, at, captured=1.14), ReachTo)
    # the seed strategy reads frames as they come, as the paper does
    seed = _lander(LandingStrategy.SEED)
    _seen(seed, 0.1, at, captured=0.05)
    assert isinstance(_seen(seed, 0.2, at, captured=0.15), ReachTo)
    seed.move_ended(1.0)
    _seen(seed, 1.03, at, captured=0.98)
    assert isinstance(_seen(seed, 1.11, at, captured=1.06), ReachTo)


def test_frames_exposed_before_a_move_was_sent_never_count_for_the_next_decision():
    """Without ``move_ended`` (the move's end unknown), a frame exposed before the move
    was commanded is still stale."""
    lander = _lander()
    at = (4.9, 3.0, 1.5)
    _seen(lander, 0.1, at)
    assert isinstance(_seen(lander, 0.2, at), ReachTo)
    assert _seen(lander, 0.3, at, captured=0.15) == Wait("a move is being flown")
    assert _seen(lander, 0.4, at, captured=0.25) == Wait("a move is being flown")
    assert isinstance(_seen(lander, 0.5, at, captured=0.35), ReachTo)


def test_capture_hands_the_final_landing_over_only_within_land_radius_untruncated():
    """At the lowest step, 2.9 cm off in x and y (4.1 cm): truncated to (2, 2) cm it is
    2.8 cm, inside the 3 cm align radius, and the seed lands there, 4 cm off, since the
    flight controller descends where the vehicle is. CAPTURE compares the error itself
    with land_radius (2 cm): it centres at the same altitude first, then lands."""
    kw = {"min_fresh_frames": 1, "align_radius": 0.03, "land_radius": 0.02}
    at = (PAD[0] - 0.029, PAD[1] - 0.029, 0.8)
    seed = _lander(LandingStrategy.SEED, **kw)
    seed.reference_altitude = 0.8
    assert isinstance(_seen(seed, 0.1, at), LandNow)
    ours = _lander(**kw)
    ours.reference_altitude = 0.8
    cmd = _seen(ours, 0.1, at)
    assert cmd == ReachTo((pytest.approx(at[0] + 0.02), pytest.approx(at[1] + 0.02), 0.8))
    assert ours.phase is not Phase.FINAL_LAND and ours.reference_altitude == 0.8
    centred = (cmd.position[0], cmd.position[1], 0.8)  # 1.3 cm off
    assert isinstance(_seen(ours, 0.2, centred), LandNow)
    assert ours.phase is Phase.FINAL_LAND


def test_capture_averages_the_pad_position_since_it_was_found_then_filters_slowly():
    """The pad does not move: its estimates are averaged (gain 1/n) down to
    ``pad_filter_gain``; a restart after a loss starts the average again."""
    lander = _lander(min_fresh_frames=1, pad_filter_gain=0.25)
    at = (4.5, 3.0, 1.5)
    pose = Pose(at, 0.0)
    xs = [0.50, 0.56, 0.44, 0.54]
    for k, x in enumerate(xs):
        lander.on_frame(0.1 * k, Measurement((x, 0.0), 1.5), pose, at, 0.0, True)
    assert lander.filtered == pytest.approx([4.5 + sum(xs) / 4, 3.0])
    before = lander.filtered.copy()
    lander.on_frame(0.5, Measurement((0.6, 0.0), 1.5), pose, at, 0.0, True)
    assert lander.filtered == pytest.approx(before + 0.25 * (np.array([5.1, 3.0]) - before))
