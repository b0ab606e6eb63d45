"""Takeoff, alone: offboard asked for when needed, refused, never entered; the climb."""

from __future__ import annotations

import numpy as np
import pytest

from flight_control.behaviours import (
    OFFBOARD,
    CommandReply,
    ReachTuning,
    Setpoint,
    Takeoff,
)
from flight_control.policy import Outcome
from tests.flight_control.behaviours.observe import TICK_NS, observe

TUNING = ReachTuning(spacing=0.5, acceleration=1.0, waypoint_radius=0.3, stop_speed=0.15,
                     settle_s=0.3)
HOME = np.array([1.0, 2.0, 0.1])
START = Setpoint.hold(HOME, 0.7)
MODE_WAIT_S = 1.0


def _takeoff(altitude: float = 1.5) -> Takeoff:
    return Takeoff(START, HOME, HOME, altitude=altitude, speed=0.8, radius=0.15,
                   tuning=TUNING, mode_wait_s=MODE_WAIT_S)


def _accepted() -> CommandReply:
    return CommandReply(OFFBOARD, True, "DO_SET_MODE accepted")


def test_in_offboard_already_it_climbs_to_the_altitude_above_home() -> None:
    takeoff = _takeoff()
    position = HOME.copy()
    for k in range(400):
        step = takeoff.step(observe(position), k * TICK_NS)
        assert step.command is None
        assert step.setpoint is not None
        if step.outcome is not None:
            break
        position = step.setpoint.position.copy()
    assert step.outcome is Outcome.SUCCEEDED
    assert step.setpoint is not None
    assert step.setpoint.position.tolist() == pytest.approx([1.0, 2.0, 1.6])
    assert step.setpoint.yaw == pytest.approx(0.7)  # keeps the heading it had
    assert takeoff.expected_s == pytest.approx(takeoff.climb.expected_s)


def test_feedback_is_the_height_above_home_and_what_is_left() -> None:
    takeoff = _takeoff()
    step = takeoff.step(observe(HOME + [0.0, 0.0, 0.5]), 0)
    assert step.feedback.altitude == pytest.approx(0.5)
    assert step.feedback.distance_left == pytest.approx(1.0)
    step = takeoff.step(observe(HOME + [0.0, 0.0, 1.7]), TICK_NS)
    assert step.feedback.distance_left == pytest.approx(0.2)  # above it: still positive


def test_armed_but_not_in_offboard_it_asks_for_offboard_once_holding_still() -> None:
    takeoff = _takeoff()
    first = takeoff.step(observe(HOME, offboard=False), 0)
    assert first.command == OFFBOARD and first.outcome is None
    assert first.setpoint is START
    assert first.feedback.altitude == 0.0 and first.feedback.distance_left == pytest.approx(1.5)
    second = takeoff.step(observe(HOME, offboard=False), TICK_NS)
    assert second.command is None and second.outcome is None and second.setpoint is START
    assert second.feedback.distance_left == pytest.approx(1.5)


def test_a_refused_mode_change_ends_it_with_the_fcu_s_reason() -> None:
    takeoff = _takeoff()
    takeoff.step(observe(HOME, offboard=False), 0)
    refused = CommandReply(OFFBOARD, False, "DO_SET_MODE refused by the FCU: DENIED")
    step = takeoff.step(observe(HOME, offboard=False, reply=refused), TICK_NS)
    assert step.outcome is Outcome.FCU_REJECTED
    assert step.reason == "DO_SET_MODE refused by the FCU: DENIED"
    assert step.setpoint is START and step.feedback.altitude == 0.0


def test_an_accepted_mode_that_never_shows_ends_it_after_mode_wait_s() -> None:
    takeoff = _takeoff()
    takeoff.step(observe(HOME, offboard=False), 0)
    t0 = TICK_NS
    waiting = [takeoff.step(observe(HOME, offboard=False, reply=_accepted()),
                            t0 + k * TICK_NS) for k in range(21)]
    assert [s.outcome for s in waiting] == [None] * 21  # up to and including mode_wait_s
    assert all(s.setpoint is START and s.feedback.altitude == 0.0 for s in waiting)
    step = takeoff.step(observe(HOME, offboard=False, reply=_accepted()),
                        t0 + round(MODE_WAIT_S * 1e9) + 1)  # 1 ns over
    assert step.outcome is Outcome.FCU_REJECTED and step.reason == "offboard not entered"
    assert step.setpoint is START and step.feedback.distance_left == pytest.approx(1.5)


def test_once_offboard_shows_it_climbs() -> None:
    takeoff = _takeoff()
    takeoff.step(observe(HOME, offboard=False), 0)
    takeoff.step(observe(HOME, offboard=False, reply=_accepted()), TICK_NS)
    step = takeoff.step(observe(HOME, reply=_accepted()), 2 * TICK_NS)
    assert step.outcome is None and step.command is None
    step = takeoff.step(observe(HOME, reply=_accepted()), 12 * TICK_NS)
    assert step.setpoint is not None and step.setpoint.position[2] > HOME[2]
    assert step.setpoint.velocity[2] > 0.0


def test_losing_offboard_during_the_climb_ends_it() -> None:
    takeoff = _takeoff()
    takeoff.step(observe(HOME), 0)
    step = takeoff.step(observe(HOME + [0, 0, 0.3], offboard=False), TICK_NS)
    assert step.outcome is Outcome.LOST_CONTROL


def test_in_the_air_out_of_offboard_it_takes_offboard_back_and_climbs_where_it_is() -> None:
    """A mission resumed after the FCU's failsafe flew (the link was lost): the vehicle is
    3 m away from its take-off point; offboard is asked for, then the climb ends above
    where the vehicle is, at the altitude above home, not back over the take-off point."""
    here = HOME + [3.0, -2.0, 0.8]
    takeoff = Takeoff(Setpoint.hold(here, 0.7), here, HOME, altitude=1.5, speed=0.8,
                      radius=0.15, tuning=TUNING, mode_wait_s=MODE_WAIT_S, over=here)
    first = takeoff.step(observe(here, offboard=False), 0)
    assert first.command == OFFBOARD
    takeoff.step(observe(here, offboard=False, reply=_accepted()), TICK_NS)
    position = here.copy()
    for k in range(2, 400):
        step = takeoff.step(observe(position, reply=_accepted()), k * TICK_NS)
        assert step.setpoint is not None
        if step.outcome is not None:
            break
        position = step.setpoint.position.copy()
    assert step.outcome is Outcome.SUCCEEDED
    assert step.setpoint is not None
    assert step.setpoint.position.tolist() == pytest.approx([4.0, 0.0, 1.6])
