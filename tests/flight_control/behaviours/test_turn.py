"""Turn, alone: the yaw ramp, the tolerance, lost control."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flight_control.behaviours import Setpoint, Turn
from flight_control.policy import Outcome
from tests.flight_control.behaviours.observe import TICK_NS, observe

AT = np.array([2.0, 3.0, 1.5])


def _turn(start_yaw: float, target: float, tolerance: float = 0.05,
          rate: float = 1.0) -> Turn:
    return Turn(Setpoint.hold(AT, start_yaw), target_yaw=target, rate=rate, tolerance=tolerance)


def test_the_setpoint_turns_at_the_rate_holding_the_position() -> None:
    assert _turn(0.0, 1.0, rate=2.0).expected_s == pytest.approx(0.5)
    turn = _turn(0.0, 1.0)
    assert turn.expected_s == pytest.approx(1.0)
    first = turn.step(observe(AT), 0)
    assert first.setpoint is not None and first.setpoint.yaw == 0.0
    step = turn.step(observe(AT), 500_000_000)
    assert step.setpoint is not None
    assert step.setpoint.yaw == pytest.approx(0.5)
    assert step.setpoint.position.tolist() == AT.tolist()
    assert step.setpoint.velocity.tolist() == [0.0, 0.0, 0.0]
    assert step.feedback.yaw == 0.0 and step.feedback.angle_left == pytest.approx(1.0)


def test_it_turns_the_short_way_across_pi() -> None:
    turn = _turn(3.0, -3.0)
    assert turn.expected_s == pytest.approx(2 * math.pi - 6.0)
    turn.step(observe(AT, yaw=3.0), 0)
    step = turn.step(observe(AT, yaw=3.0), 100_000_000)
    assert step.setpoint is not None and step.setpoint.yaw == pytest.approx(3.1)


def test_it_succeeds_with_the_setpoint_at_the_target_and_the_vehicle_within_tolerance() -> None:
    turn = _turn(0.0, 0.5, tolerance=0.25)
    turn.step(observe(AT), 0)
    # the setpoint is there after 0.5 s, the vehicle lags outside the tolerance
    assert turn.step(observe(AT, yaw=0.1), 10 * TICK_NS).outcome is None
    assert turn.step(observe(AT, yaw=0.2), 11 * TICK_NS).outcome is None
    step = turn.step(observe(AT, yaw=0.25), 12 * TICK_NS)  # exactly the tolerance
    assert step.outcome is Outcome.SUCCEEDED
    assert step.setpoint is not None and step.setpoint.yaw == 0.5
    assert step.feedback.yaw == 0.25 and step.feedback.angle_left == 0.25


def test_the_vehicle_at_the_target_is_not_enough_while_the_setpoint_ramps() -> None:
    turn = _turn(0.0, 1.0)
    turn.step(observe(AT, yaw=1.0), 0)
    assert turn.step(observe(AT, yaw=1.0), TICK_NS).outcome is None


def test_losing_offboard_control_ends_it() -> None:
    turn = _turn(0.0, 1.0)
    step = turn.step(observe(AT, yaw=0.5, offboard=False), 0)
    assert step.outcome is Outcome.LOST_CONTROL and step.setpoint is None
    assert step.feedback.yaw == 0.5 and step.feedback.angle_left == pytest.approx(0.5)


def test_a_zero_rate_is_refused() -> None:
    with pytest.raises(ValueError, match=r"rate: 0.0 rad/s must be > 0"):
        Turn(Setpoint.hold(AT, 0.0), target_yaw=1.0, rate=0.0, tolerance=0.05)
