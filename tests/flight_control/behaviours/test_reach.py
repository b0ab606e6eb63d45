"""Reach, alone: carrot, settling, pass-through, lost control."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from flight_control.behaviours import Reach, ReachTuning, Setpoint
from flight_control.policy import Outcome
from flight_control.setpoints import ReachPlan
from tests.flight_control.behaviours.observe import TICK_NS, observe

TUNING = ReachTuning(spacing=0.5, acceleration=1.0, waypoint_radius=0.3, stop_speed=0.15,
                     settle_s=0.3)
START = Setpoint.hold(np.array([0.0, 0.0, 1.0]), 0.0)


def _reach(target: tuple[float, float, float] = (2.0, 0.0, 1.0), *, stop: bool = True,
           settle_s: float = 0.3, radius: float = 0.15) -> Reach:
    tuning = ReachTuning(TUNING.spacing, TUNING.acceleration, TUNING.waypoint_radius,
                         TUNING.stop_speed, settle_s)
    return Reach.toward(START, START.position, target, speed=1.0, radius=radius,
                        tuning=tuning, stop_at_target=stop, target_yaw=None)


def _fly(reach: Reach, limit_s: float = 20.0) -> tuple[int, list[float], Outcome | None]:
    """A vehicle that is where the last setpoint was; (end ns, distances, outcome)."""
    position = START.position.copy()
    distances = []
    for k in range(round(limit_s * 1e9 / TICK_NS)):
        step = reach.step(observe(position), k * TICK_NS)
        distances.append(step.feedback.distance_left)
        if step.outcome is not None:
            assert step.setpoint is not None
            assert step.setpoint.position.tolist() == reach.plan.target.tolist()
            assert step.setpoint.velocity.tolist() == [0.0, 0.0, 0.0]
            return k * TICK_NS, distances, step.outcome
        assert step.setpoint is not None
        position = step.setpoint.position.copy()
    return -1, distances, None


def test_a_vehicle_on_the_carrot_reaches_and_settles_in_the_expected_time() -> None:
    reach = _reach()
    end_ns, distances, outcome = _fly(reach)
    assert outcome is Outcome.SUCCEEDED
    assert distances[0] == pytest.approx(2.0)
    assert distances == sorted(distances, reverse=True)  # counts down
    expected = ReachPlan.build(START.position, (2.0, 0.0, 1.0), spacing=0.5, cruise_speed=1.0,
                               acceleration=1.0, waypoint_radius=0.3).expected_duration()
    assert reach.expected_s == pytest.approx(expected)
    assert end_ns / 1e9 == pytest.approx(expected + 0.3, abs=0.2)  # + settle_s


def test_success_waits_settle_s_inside_the_radius() -> None:
    reach = _reach(settle_s=1.0)
    target = reach.plan.target
    # the carrot is at the end, the vehicle inside the radius and still
    reach.progress = type(reach.progress)(reach.plan.length, 0.0, len(reach.plan.points) - 1)
    near = target + np.array([0.1, 0.0, 0.0])
    outcomes = [reach.step(observe(near), k * TICK_NS).outcome for k in range(21)]
    assert outcomes[:20] == [None] * 20  # 0 .. 0.95 s: settling
    assert outcomes[20] is Outcome.SUCCEEDED  # 1.0 s


def test_moving_or_leaving_the_radius_restarts_the_settling() -> None:
    reach = _reach(settle_s=0.2)
    reach.progress = type(reach.progress)(reach.plan.length, 0.0, len(reach.plan.points) - 1)
    target = reach.plan.target
    assert reach.step(observe(target), 0).outcome is None
    assert reach.step(observe(target, velocity=(0.5, 0, 0)), TICK_NS).outcome is None
    assert reach.step(observe(target + [0.5, 0, 0]), 2 * TICK_NS).outcome is None
    assert reach.step(observe(target), 3 * TICK_NS).outcome is None  # settling again from here
    assert reach.step(observe(target), 6 * TICK_NS).outcome is None  # 0.15 s
    assert reach.step(observe(target), 7 * TICK_NS).outcome is Outcome.SUCCEEDED  # 0.2 s


def test_stop_speed_is_inclusive() -> None:
    reach = _reach(settle_s=0.0)
    reach.progress = type(reach.progress)(reach.plan.length, 0.0, len(reach.plan.points) - 1)
    at = observe(reach.plan.target, velocity=(TUNING.stop_speed, 0.0, 0.0))
    assert reach.step(at, 0).outcome is Outcome.SUCCEEDED


def test_the_radius_is_inclusive_and_outside_it_there_is_no_success() -> None:
    reach = _reach(settle_s=0.0, radius=0.25)
    reach.progress = type(reach.progress)(reach.plan.length, 0.0, len(reach.plan.points) - 1)
    target = reach.plan.target
    assert reach.step(observe(target + [0.0, 0.26, 0.0]), 0).outcome is None
    assert reach.step(observe(target + [0.0, 0.25, 0.0]), TICK_NS).outcome is Outcome.SUCCEEDED


def test_no_success_before_the_carrot_is_at_the_end() -> None:
    reach = _reach(settle_s=0.0)
    # the vehicle is already at the target, but the carrot has just left
    step = reach.step(observe(reach.plan.target), 0)
    assert step.outcome is None


def test_passing_through_succeeds_at_arrival_without_settling_or_stopping() -> None:
    reach = _reach(stop=False, settle_s=5.0)
    reach.progress = type(reach.progress)(reach.plan.length, 1.0, len(reach.plan.points) - 1)
    step = reach.step(observe(reach.plan.target, velocity=(1.0, 0.0, 0.0)), 0)
    assert step.outcome is Outcome.SUCCEEDED
    assert step.feedback.distance_left == 0.0


def test_by_default_it_stops_at_the_target_and_keeps_the_heading_it_had() -> None:
    reach = Reach.toward(Setpoint.hold(START.position, 0.3), START.position, (2.0, 0.0, 1.0),
                         speed=1.0, radius=0.15, tuning=TUNING)
    assert reach.plan.stop_at_target and reach.plan.target_yaw == pytest.approx(0.3)
    turning = Reach.toward(START, START.position, (2.0, 0.0, 1.0), speed=1.0, radius=0.15,
                           tuning=TUNING, target_yaw=1.2)
    assert turning.plan.target_yaw == pytest.approx(1.2)
    turning.step(observe(START.position), 0)
    # the carrot waits at the first setpoint the vehicle has not reached, 1 m of 2 m
    halfway = turning.step(observe((0.3, 0.0, 1.0)), 2_000_000_000)
    assert halfway.setpoint is not None
    assert halfway.setpoint.yaw == pytest.approx(0.6)


def test_the_carrot_accelerates_from_the_start_along_the_segment() -> None:
    reach = _reach()
    first = reach.step(observe(START.position), 0)
    assert first.setpoint is not None and first.setpoint.position.tolist() == [0.0, 0.0, 1.0]
    second = reach.step(observe(START.position), 500_000_000)  # 0.5 s at 1 m/s^2
    assert second.setpoint is not None
    assert second.setpoint.velocity.tolist() == pytest.approx([0.5, 0.0, 0.0])
    assert second.setpoint.position.tolist() == pytest.approx([0.25, 0.0, 1.0])
    assert second.feedback.position.tolist() == [0.0, 0.0, 1.0]


@pytest.mark.parametrize(("velocity", "speed"), [
    ((0.8, 0.6, 0.0), 0.8),  # the part along the segment: a reach after one passed on the way
    ((-0.5, 0.0, 0.0), 0.0),  # backwards: from rest, as before
    ((3.0, 0.0, 0.0), 1.0),  # never above the reach's speed
])
def test_the_carrot_starts_at_the_vehicles_speed_along_the_segment(
        velocity: tuple[float, float, float], speed: float) -> None:
    reach = Reach.toward(START, START.position, (4.0, 0.0, 1.0), speed=1.0, radius=0.15,
                         tuning=TUNING, velocity=velocity)
    first = reach.step(observe(START.position, velocity=velocity), 0)
    assert first.setpoint is not None
    assert first.setpoint.velocity.tolist() == pytest.approx([speed, 0.0, 0.0])
    later = reach.step(observe(START.position, velocity=velocity), 200_000_000)  # 0.2 s
    assert later.setpoint is not None  # accelerating from there at 1 m/s^2, up to 1 m/s
    assert later.setpoint.velocity[0] == pytest.approx(min(speed + 0.2, 1.0))
    assert later.setpoint.position[0] == pytest.approx(min(speed + 0.2, 1.0) * 0.2)


@pytest.mark.parametrize("kwargs", [{"offboard": False}, {"armed": False}, {"stale": True}])
def test_losing_offboard_control_ends_it(kwargs: dict[str, Any]) -> None:
    reach = _reach()
    step = reach.step(observe(START.position, **kwargs), 0)
    assert step.outcome is Outcome.LOST_CONTROL
    assert step.setpoint is None  # the stream is left alone
    assert step.feedback.distance_left == pytest.approx(2.0)
