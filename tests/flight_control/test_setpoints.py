"""Setpoint interpolation, the reach sphere, yaw ramps and goal validation: pure tests."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_control.goal_checks import (
    FieldBounds,
    GoalError,
    VehicleState,
    check_speed,
    check_takeoff_altitude,
    check_target,
    check_vehicle,
    fmt_m,
)
from flight_control.setpoints import (
    ReachPlan,
    ReachProgress,
    inside_sphere,
    interpolate_segment,
    trapezoid_duration,
    yaw_between,
    yaw_toward,
)

FIELD = FieldBounds((0.0, 0.0, 0.0), (20.0, 14.0, 4.0))
coord = st.floats(-50.0, 50.0, allow_nan=False)
point = st.tuples(coord, coord, coord)
angle = st.floats(-10.0, 10.0, allow_nan=False)


# -- interpolation ------------------------------------------------------------------------

def test_segment_is_cut_into_equal_steps_no_longer_than_the_spacing() -> None:
    points = interpolate_segment([0, 0, 1], [2.2, 0, 1], 0.5)
    assert len(points) == 5  # ceil(2.2 / 0.5)
    steps = np.linalg.norm(np.diff(np.vstack([[0, 0, 1], points]), axis=0), axis=1)
    assert steps == pytest.approx([0.44] * 5)
    assert points[-1].tolist() == [2.2, 0.0, 1.0]


def test_zero_length_segment_is_the_target_alone() -> None:
    assert interpolate_segment([1, 2, 3], [1, 2, 3], 0.5).tolist() == [[1.0, 2.0, 3.0]]


def test_bad_inputs_say_what_is_wrong() -> None:
    with pytest.raises(ValueError, match="spacing"):
        interpolate_segment([0, 0, 0], [1, 0, 0], 0.0)
    with pytest.raises(ValueError, match="target"):
        interpolate_segment([0, 0, 0], [1, math.nan, 0], 0.5)


@settings(max_examples=200, deadline=None)
@given(point, point, st.floats(0.05, 5.0))
def test_interpolated_points_lie_on_the_segment_in_order(a: tuple[float, float, float],
                                                        b: tuple[float, float, float],
                                                        spacing: float) -> None:
    start, target = np.array(a), np.array(b)
    points = interpolate_segment(start, target, spacing)
    assert np.array_equal(points[-1], target)
    length = float(np.linalg.norm(target - start))
    steps = np.linalg.norm(np.diff(np.vstack([start, points]), axis=0), axis=1)
    assert np.all(steps <= spacing + 1e-9)
    if length > 0:
        assert steps == pytest.approx(np.full(len(points), length / len(points)), abs=1e-9)
        # on the segment: distance from the line is zero
        u = (target - start) / length
        rel = points - start
        off_line = rel - np.outer(rel @ u, u)
        assert np.abs(off_line).max() < 1e-6
        assert np.all(np.diff(rel @ u) > 0)  # in order from start to target


# -- the reach sphere -----------------------------------------------------------------------

def test_inside_sphere_includes_its_surface() -> None:
    assert inside_sphere([0.3, 0, 0], [0, 0, 0], 0.3)
    assert not inside_sphere([0.30001, 0, 0], [0, 0, 0], 0.3)


def _plan(length: float = 3.0, **kw: float | bool) -> ReachPlan:
    args: dict = dict(spacing=0.5, cruise_speed=1.0, acceleration=1.0, waypoint_radius=0.3)
    args.update(kw)
    return ReachPlan.build([0, 0, 1], [length, 0, 1], **args)


def test_setpoints_are_reached_in_sequence_only_inside_their_sphere() -> None:
    plan = _plan()
    progress = ReachProgress()
    # vehicle still at the start: the first setpoint (0.5 m away) is not reached
    progress = plan.advance(progress, [0, 0, 1], 0.05)
    assert progress.next_index == 0
    # at 0.25 m from the first setpoint: reached, the next one (1.0 m) is 0.75 m away
    progress = plan.advance(progress, [0.25, 0, 1], 0.05)
    assert progress.next_index == 1
    # a vehicle that jumps near the 4th setpoint does not skip the 2nd and 3rd...
    progress = plan.advance(ReachProgress(), [2.0, 0.5, 1], 0.05)
    assert progress.next_index == 0
    # ...but one that sits inside several spheres at once reaches them one after another
    dense = _plan(spacing=0.1)
    progress = dense.advance(ReachProgress(), [0.25, 0, 1], 0.05)
    assert progress.next_index == 5  # points 0.1 .. 0.5 are inside 0.3 m of x = 0.25


def test_the_carrot_waits_at_the_next_unreached_setpoint() -> None:
    plan = _plan()
    progress = ReachProgress()
    for _ in range(100):  # 5 s with the vehicle stuck at the start
        progress = plan.advance(progress, [0, 0, 1], 0.05)
    assert progress.s == pytest.approx(0.5)  # the first setpoint, no further
    assert progress.speed == 0.0
    carrot = plan.carrot(progress)
    assert carrot.position == pytest.approx([0.5, 0, 1])
    assert carrot.velocity == pytest.approx([0, 0, 0])


def test_the_carrot_follows_a_trapezoid_and_stops_on_the_target() -> None:
    plan = _plan(length=4.0)
    progress = ReachProgress()
    speeds, t = [], 0.0
    while progress.s < plan.length and t < 20.0:
        progress = plan.advance(progress, plan.carrot(progress).position, 0.05)
        speeds.append(progress.speed)
        t += 0.05
    assert progress.s == plan.length and progress.speed == 0.0
    assert max(speeds) == pytest.approx(1.0)  # cruise
    # acceleration-limited (a = 1 m/s^2, dt = 0.05 s), but for the snap onto the target
    assert np.abs(np.diff(speeds[:-1])).max() <= 1.0 * 0.05 * 1.25
    assert speeds[-2] < 0.15
    assert t == pytest.approx(plan.expected_duration(), abs=0.3)


def test_pass_through_keeps_cruise_speed_at_the_target() -> None:
    plan = _plan(length=4.0, stop_at_target=False)
    progress = ReachProgress()
    for _ in range(200):
        progress = plan.advance(progress, plan.carrot(progress).position, 0.05)
    assert progress.s == plan.length
    assert plan.carrot(progress).velocity == pytest.approx([1.0, 0, 0])


@settings(max_examples=100, deadline=None)
@given(point, point, st.floats(0.1, 2.0), st.floats(0.2, 3.0), st.floats(0.1, 2.0))
def test_a_vehicle_on_the_carrot_always_arrives(a: tuple[float, float, float],
                                               b: tuple[float, float, float],
                                               spacing: float, speed: float,
                                               accel: float) -> None:
    plan = ReachPlan.build(a, b, spacing=spacing, cruise_speed=speed, acceleration=accel,
                           waypoint_radius=0.3)
    progress = ReachProgress()
    steps = 0
    limit = int(plan.expected_duration() / 0.05) + 50
    while progress.s < plan.length and steps < limit:
        progress = plan.advance(progress, plan.carrot(progress).position, 0.05)
        assert progress.speed <= speed + 1e-9
        steps += 1
    assert progress.s == pytest.approx(plan.length)
    assert plan.carrot(progress).position == pytest.approx(np.array(b), abs=1e-6)


def test_trapezoid_duration() -> None:
    assert trapezoid_duration(4.0, 1.0, 1.0) == pytest.approx(5.0)  # 1 s up, 3 s, 1 s down
    assert trapezoid_duration(0.25, 1.0, 1.0) == pytest.approx(1.0)  # triangle
    assert trapezoid_duration(0.0, 1.0, 1.0) == 0.0


# -- yaw ------------------------------------------------------------------------------------

def test_yaw_turns_the_short_way_at_the_rate() -> None:
    assert yaw_toward(3.0, -3.0, 0.1, 1.0) == pytest.approx(3.1)  # through pi, not through 0
    assert yaw_toward(0.0, 0.05, 1.0, 0.1) == pytest.approx(0.05)  # arrives exactly
    assert yaw_between(3.0, -3.0, 0.5) == pytest.approx(math.pi)


@settings(max_examples=200, deadline=None)
@given(angle, angle, st.floats(0.05, 3.0), st.floats(0.0, 0.2))
def test_yaw_step_is_bounded_and_never_passes_the_target(current: float, target: float,
                                                         rate: float, dt: float) -> None:
    new = yaw_toward(current, target, rate, dt)
    step = abs(math.remainder(new - current, 2 * math.pi))
    assert step <= rate * dt + 1e-9
    before = abs(math.remainder(target - current, 2 * math.pi))
    after = abs(math.remainder(target - new, 2 * math.pi))
    assert after <= before + 1e-9
    assert -math.pi < new <= math.pi


# -- goal validation ------------------------------------------------------------------------

def test_outside_the_field_is_rejected_with_the_numbers() -> None:
    problem = check_target([25.0, 3.0, 1.5], FIELD, 0.5)
    assert problem is not None and problem.error is GoalError.OUTSIDE_FIELD
    assert problem.message == (
        "target (25.0, 3.0, 1.5) m is outside the flyable volume [0, 20] x [0, 14] x [0, 4] m")


def test_shrunk_keeps_clear_of_walls_and_ceiling_but_not_the_floor() -> None:
    inner = FIELD.shrunk(0.4)
    assert inner.lower == (0.4, 0.4, 0.0)
    assert inner.upper == (19.6, 13.6, 3.6)
    with pytest.raises(ValueError, match="on z"):
        FIELD.shrunk(4.0)  # a 4 m ceiling leaves nothing above the floor


def test_below_the_floor_and_not_finite() -> None:
    problem = check_target([5.0, 3.0, 0.2], FIELD, 0.5)
    assert problem is not None and problem.error is GoalError.BELOW_FLOOR
    assert problem.message == "target altitude 0.2 m is below the floor 0.5 m"
    problem = check_target([5.0, math.inf, 1.0], FIELD, 0.5)
    assert problem is not None and problem.error is GoalError.NOT_FINITE
    assert check_target([5.0, 3.0, 1.5], FIELD, 0.5) is None


@settings(max_examples=200, deadline=None)
@given(point)
def test_a_target_is_accepted_exactly_when_inside_and_above_the_floor(
        p: tuple[float, float, float]) -> None:
    inside = all(lo <= v <= hi for v, lo, hi in zip(p, FIELD.lower, FIELD.upper, strict=True))
    ok = inside and p[2] >= 0.5
    assert (check_target(p, FIELD, 0.5) is None) == ok


def _state(**kw: bool | int) -> VehicleState:
    base: dict = dict(connected=True, armed=True, landed=False, position_valid=True,
                      battery_warning=0, offboard=True, nav_state=14)
    base.update(kw)
    return VehicleState(**base)


@pytest.mark.parametrize(("state", "error", "message"), [
    (None, GoalError.FCU_DISCONNECTED, "FCU not connected"),
    (_state(position_valid=False), GoalError.NO_POSITION, "no valid position estimate"),
    (_state(battery_warning=2), GoalError.BATTERY_CRITICAL,
     "battery critical (warning level 2)"),
    (_state(armed=False), GoalError.NOT_ARMED, "not armed"),
    (_state(landed=True), GoalError.NOT_FLYING, "not flying (landed)"),
    (_state(offboard=False, nav_state=4), GoalError.NOT_IN_CONTROL,
     "not in offboard control (FCU AUTO_LOITER (nav_state 4))"),
])
def test_vehicle_checks_name_the_problem(state: VehicleState | None, error: GoalError,
                                         message: str) -> None:
    problem = check_vehicle(state, battery_critical_warning=2, need_armed=True,
                            need_flying=True, need_offboard=True)
    assert problem is not None
    assert (problem.error, problem.message) == (error, message)


def test_landing_is_allowed_on_a_critical_battery() -> None:
    assert check_vehicle(_state(battery_warning=3), battery_critical_warning=None,
                         need_armed=True) is None
    assert check_vehicle(_state(battery_warning=1), battery_critical_warning=2) is None


def test_takeoff_altitude_and_speed_limits() -> None:
    problem = check_takeoff_altitude(4.5, 0.15, FIELD, 0.5)
    assert problem is not None and problem.error is GoalError.OUTSIDE_FIELD
    assert "above the field's ceiling 4 m" in problem.message
    problem = check_takeoff_altitude(0.2, 0.15, FIELD, 0.5)
    assert problem is not None and problem.error is GoalError.BELOW_FLOOR
    assert check_takeoff_altitude(1.5, 0.15, FIELD, 0.5) is None
    assert check_speed(0.0, 2.0) is None
    problem = check_speed(3.0, 2.0)
    assert problem is not None and problem.error is GoalError.TOO_FAST


def test_field_bounds_must_be_a_box() -> None:
    with pytest.raises(ValueError, match="on y"):
        FieldBounds((0.0, 5.0, 0.0), (20.0, 5.0, 4.0))
    assert FIELD.describe() == "[0, 20] x [0, 14] x [0, 4] m"
    assert [fmt_m(v) for v in (25.0, 1.55, 0.2, -3.0)] == ["25.0", "1.55", "0.2", "-3.0"]
