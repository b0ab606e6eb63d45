"""The action base, through the node's actions on a scripted FCU: preemption, cancel,
timeout, feedback rate, goal checks and result mapping, once for all four actions."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from flight_control.behaviour_server import MotionAction, Needs
from flight_control.flight_actions import REACH
from flight_control.policy import Outcome
from flight_control.setpoints import trapezoid_duration
from interfaces.px4 import NavigationState, VehicleCmd
from runtime import GoalStatus
from tests.flight_control.rig import make_rig, reach_goal

AT = (2.0, 2.0, 1.5)


def test_a_newer_goal_preempts_the_running_one() -> None:
    rig = make_rig(flying_at=AT)
    rig.fcu.speed = 0.5
    first = rig.send("reach", **reach_goal(8.0, 2.0, 1.5))
    assert first.accepted
    rig.ex.spin_for(1.0)
    second = rig.send("reach", **reach_goal(2.0, 3.0, 1.5))
    assert second.accepted
    preempted = rig.result(first, 1.0)
    assert preempted.status == GoalStatus.ABORTED
    assert preempted.result.message == "preempted by a newer goal"
    assert preempted.result.result == preempted.result.RESULT_CANCELED
    assert not preempted.result.success
    done = rig.result(second, 20.0)
    assert done.status == GoalStatus.SUCCEEDED, done.result.message
    assert done.result.distance_error <= 0.15


def test_cancel_holds_where_the_vehicle_is() -> None:
    rig = make_rig(flying_at=AT)
    handle = rig.send("reach", **reach_goal(8.0, 2.0, 1.5))
    rig.ex.spin_for(2.0)
    rig.wait(handle.cancel_goal_async(), 1.0)
    canceled = rig.result(handle, 1.0)
    assert canceled.status == GoalStatus.CANCELED
    assert canceled.result.result == canceled.result.RESULT_CANCELED
    sp = rig.fc.setpoint
    assert sp is not None
    assert sp.velocity.tolist() == [0.0, 0.0, 0.0]
    where = np.array([canceled.result.position.x, canceled.result.position.y,
                      canceled.result.position.z])
    assert np.linalg.norm(sp.position - where) < 0.03  # one odometry period at 1 m/s
    assert where[0] < 5.0  # stopped well short of x = 8
    rig.ex.spin_for(2.0)
    assert np.linalg.norm(rig.fcu.position - sp.position) < 1e-9  # held there


def test_a_goal_that_takes_too_long_times_out_at_factor_times_expected_plus_margin() -> None:
    rig = make_rig(flying_at=AT)
    rig.fcu.speed = 0.0  # the vehicle never moves
    p = rig.fc.params
    handle = rig.send("reach", **reach_goal(3.0, 2.0, 1.5))
    t0 = rig.t()
    out = rig.result(handle, 60.0)
    took = rig.t() - t0
    limit = p.timeout_factor * trapezoid_duration(1.0, p.cruise_speed, p.acceleration) \
        + p.timeout_margin_s
    assert out.status == GoalStatus.ABORTED
    assert out.result.result == out.result.RESULT_TIMEOUT
    assert limit <= took <= limit + 2 * p.period_s
    assert out.result.message.startswith(f"timed out after {limit:.1f} s: stopped 1.0 m from")
    assert rig.fc.setpoint is not None and rig.fc.setpoint.velocity.tolist() == [0, 0, 0]


def test_feedback_comes_at_feedback_rate_hz() -> None:
    rig = make_rig(flying_at=AT)
    rig.fcu.speed = 0.0
    feedback: list[Any] = []
    handle = rig.send("reach", feedback, **reach_goal(6.0, 2.0, 1.5))
    rig.ex.spin_for(4.0)
    rig.wait(handle.cancel_goal_async(), 1.0)
    rate = rig.fc.params.feedback_rate_hz
    assert len(feedback) in (round(4.0 * rate), round(4.0 * rate) + 1)
    assert feedback[0].distance_left == pytest.approx(4.0)


def test_a_bad_goal_is_rejected_with_the_reason() -> None:
    rig = make_rig(flying_at=AT)
    handle = rig.send("reach", **reach_goal(12.0, 2.0, 1.5))
    assert not handle.accepted
    assert rig.result(handle).result.message == \
        "target (12.0, 2.0, 1.5) m is outside the flyable volume [0.4, 9.6] x [0.4, 7.6] x " \
        "[0, 3.6] m"
    turn = rig.send("turn", yaw=1.0, yaw_rate=9.0)
    assert not turn.accepted
    assert rig.result(turn).result.message == "speed 9.0 is above the limit 2.0"
    nan_turn = rig.send("turn", yaw=float("nan"))
    assert rig.result(nan_turn).result.message == "yaw nan is not finite"


def test_vehicle_checks_come_first_and_say_what_is_missing() -> None:
    rig = make_rig()  # on the ground, disarmed
    handle = rig.send("reach", **reach_goal(3.0, 2.0, 1.5))
    assert rig.result(handle).result.message == "not armed"
    too_slow = rig.send("land", speed=0.1)
    assert rig.result(too_slow).result.message == "not armed"


def test_losing_offboard_mid_goal_aborts_with_the_nav_state() -> None:
    rig = make_rig(flying_at=AT)
    handle = rig.send("reach", **reach_goal(8.0, 2.0, 1.5))
    rig.ex.spin_for(1.0)
    rig.fcu.offboard, rig.fcu.nav_state = False, NavigationState.AUTO_LOITER
    out = rig.result(handle, 2.0)
    assert out.status == GoalStatus.ABORTED
    assert out.result.result == out.result.RESULT_NOT_FLYING
    assert out.result.message == "lost offboard control (FCU AUTO_LOITER (nav_state 4))"


def test_turn_then_takeoff_and_land_through_the_base() -> None:
    rig = make_rig(flying_at=AT)
    turned = rig.result(rig.send("turn", yaw=0.0, relative=False), 10.0)
    assert turned.status == GoalStatus.SUCCEEDED and turned.result.result == 0
    landing = rig.send("land", disarm=True)
    assert landing.accepted
    landed = rig.result(landing, 30.0)
    assert landed.status == GoalStatus.SUCCEEDED, landed.result.message
    assert rig.fcu.sent(VehicleCmd.NAV_LAND) and rig.fcu.sent(VehicleCmd.COMPONENT_ARM_DISARM)
    assert not rig.fcu.armed and rig.fc.setpoint is None
    assert landed.result.message.startswith("landed at (2.0, 2.0, ")


def test_takeoff_asks_for_offboard_when_armed_outside_it_then_climbs() -> None:
    rig = make_rig()
    rig.fcu.armed = True
    rig.ex.spin_for(0.2)
    out = rig.result(rig.send("takeoff", altitude=1.0), 20.0)
    assert out.status == GoalStatus.SUCCEEDED, out.result.message
    assert len(rig.fcu.sent(VehicleCmd.DO_SET_MODE)) == 1
    assert out.result.position.z == pytest.approx(1.0, abs=0.15)
    assert out.result.message.startswith("at 1.0 m above the take-off point (1.0, 1.0, 0.0) m")


def test_a_refused_nav_land_is_an_fcu_rejection() -> None:
    rig = make_rig(flying_at=AT)
    rig.fcu.answers[VehicleCmd.NAV_LAND] = [2]  # DENIED
    out = rig.result(rig.send("land"), 5.0)
    assert out.status == GoalStatus.ABORTED
    assert out.result.result == out.result.RESULT_FCU_REJECTED
    assert out.result.message == "NAV_LAND refused by the FCU: DENIED (attempt 1/3)"


def test_canceling_nav_land_takes_offboard_back() -> None:
    rig = make_rig(flying_at=AT)
    handle = rig.send("land")
    rig.ex.spin_for(1.0)
    assert not rig.fcu.offboard  # the FCU is landing
    rig.wait(handle.cancel_goal_async(), 1.0)
    out = rig.result(handle, 5.0)
    assert out.status == GoalStatus.CANCELED
    assert rig.fcu.offboard and len(rig.fcu.sent(VehicleCmd.DO_SET_MODE)) == 1


def test_every_action_maps_every_outcome_to_a_result_code() -> None:
    with pytest.raises(ValueError, match="reach: no result code for TIMEOUT, CANCELED"):
        MotionAction(REACH, "reach", Needs(), lambda g: None, lambda *a: None,  # type: ignore
                     lambda f: f, lambda *a: "",
                     {o: "RESULT_OK" for o in Outcome
                      if o not in (Outcome.TIMEOUT, Outcome.CANCELED)})


def test_a_preempted_goal_stops_sending_its_fcu_command() -> None:
    rig = make_rig(flying_at=AT)
    rig.fcu.answers[VehicleCmd.NAV_LAND] = [None, None, None]  # every ack is lost
    land = rig.send("land")
    assert land.accepted
    rig.ex.spin_for(0.6)
    assert len(rig.fcu.sent(VehicleCmd.NAV_LAND)) == 2  # at 0 and after one 0.5 s timeout
    reach = rig.send("reach", **reach_goal(3.0, 2.0, 1.5))
    assert reach.accepted
    assert rig.result(land, 1.0).result.message == "preempted by a newer goal"
    done = rig.result(reach, 20.0)
    assert done.status == GoalStatus.SUCCEEDED, done.result.message
    assert len(rig.fcu.sent(VehicleCmd.NAV_LAND)) == 2  # never sent again
    assert rig.fcu.nav_state == NavigationState.OFFBOARD


def test_a_canceled_goal_stops_sending_its_fcu_command() -> None:
    rig = make_rig(flying_at=AT)
    rig.fcu.answers[VehicleCmd.NAV_LAND] = [None, None, None]
    land = rig.send("land")
    rig.ex.spin_for(0.2)
    rig.wait(land.cancel_goal_async(), 1.0)
    out = rig.result(land, 1.0)
    assert out.status == GoalStatus.CANCELED
    rig.ex.spin_for(2.0)
    assert len(rig.fcu.sent(VehicleCmd.NAV_LAND)) == 1


@pytest.mark.parametrize(("target", "accepted"), [
    ((0.2, 2.0, 1.5), False),  # 0.2 m from the west wall: inside the field, too close
    ((0.5, 2.0, 1.5), True),
    ((9.7, 2.0, 1.5), False),  # east wall at 10 m
    ((2.0, 7.7, 1.5), False),  # north wall at 8 m
    ((2.0, 2.0, 3.8), False),  # ceiling at 4 m
    ((2.0, 2.0, 3.5), True),
])
def test_reach_targets_keep_wall_clearance_from_walls_and_ceiling(
        target: tuple[float, float, float], accepted: bool) -> None:
    rig = make_rig(flying_at=AT)
    assert rig.fc.params.wall_clearance == 0.4
    handle = rig.send("reach", **reach_goal(*target))
    assert handle.accepted is accepted, rig.result(handle).result.message
