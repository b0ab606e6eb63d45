"""Land, alone: NAV_LAND or an offboard descent, touchdown, disarm, refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flight_control.behaviours import (
    DISARM,
    NAV_LAND,
    CommandReply,
    Land,
    Setpoint,
)
from flight_control.behaviours.land import DISARM_ATTEMPTS, DISARM_RETRY_NS
from flight_control.policy import Outcome
from tests.flight_control.behaviours.observe import TICK_NS, observe

AT = np.array([4.0, 5.0, 1.2])
START = Setpoint.hold(AT, 0.4)


def _land(speed: float = 0.0, disarm: bool = True) -> Land:
    return Land(START, AT, speed=speed, disarm=disarm, home_z=0.2)


def _reply(request: object, accepted: bool) -> CommandReply:
    return CommandReply(request, accepted, "ok" if accepted else "refused: DENIED")  # type: ignore[arg-type]


def test_speed_0_asks_for_nav_land_then_follows_the_vehicle_down() -> None:
    land = _land()
    assert land.expected_s is None
    first = land.step(observe(AT, offboard=False), 0)
    assert first.command == NAV_LAND and first.setpoint is START and first.outcome is None
    assert first.feedback.altitude == pytest.approx(1.0)
    lower = AT - [0.0, 0.0, 0.5]
    step = land.step(observe(lower, velocity=(0, 0, -0.7), offboard=False,
                             reply=_reply(NAV_LAND, True)), TICK_NS)
    assert step.command is None and step.outcome is None
    assert step.setpoint is not None and step.setpoint.position.tolist() == lower.tolist()
    assert step.setpoint.yaw == 0.4
    assert step.feedback.altitude == pytest.approx(0.5)
    assert step.feedback.vertical_speed == pytest.approx(-0.7)


def test_a_refused_nav_land_ends_it_with_the_reason() -> None:
    land = _land()
    land.step(observe(AT), 0)
    step = land.step(observe(AT, reply=_reply(NAV_LAND, False)), TICK_NS)
    assert step.outcome is Outcome.FCU_REJECTED and step.reason == "refused: DENIED"
    assert step.feedback.altitude == pytest.approx(1.0)


def test_a_speed_descends_in_offboard_at_that_speed_holding_x_y() -> None:
    land = _land(speed=0.5)
    step = land.step(observe(AT + [0.3, 0.0, -0.2]), 0)
    assert step.command is None and step.outcome is None
    assert step.setpoint is not None
    assert step.setpoint.position[:2].tolist() == [4.0, 5.0]
    assert math.isnan(step.setpoint.position[2])
    assert step.setpoint.velocity.tolist() == [0.0, 0.0, -0.5]
    assert step.setpoint.yaw == 0.4
    assert step.feedback.altitude == pytest.approx(0.8)


def test_touchdown_asks_for_disarm_then_succeeds_once_disarmed() -> None:
    land = _land(speed=0.5)
    ground = AT * [1, 1, 0]
    step = land.step(observe(ground, landed=True), 0)
    assert step.command == DISARM and step.outcome is None
    assert step.feedback.altitude == pytest.approx(-0.2)
    assert step.setpoint is not None and step.setpoint.position.tolist() == ground.tolist()
    step = land.step(observe(ground, landed=True, reply=_reply(DISARM, True)), TICK_NS)
    assert step.command is None and step.outcome is None  # until the status shows it
    assert step.setpoint is not None and step.setpoint.position.tolist() == ground.tolist()
    assert step.feedback.altitude == pytest.approx(-0.2)
    step = land.step(observe(ground, landed=True, armed=False, reply=_reply(DISARM, True)),
                     2 * TICK_NS)
    assert step.outcome is Outcome.SUCCEEDED
    assert step.setpoint is None  # the stream is over
    assert step.feedback.altitude == pytest.approx(-0.2)


def test_a_refused_disarm_is_asked_again_then_ends_it_after_the_last_attempt() -> None:
    land = _land(speed=0.5)
    assert land.step(observe(AT, landed=True), 0).command == DISARM
    t = 0
    for attempt in range(1, DISARM_ATTEMPTS + 1):
        refused = _reply(DISARM, False)
        t += TICK_NS
        step = land.step(observe(AT, landed=True, reply=refused), t)
        assert step.setpoint is not None and step.setpoint.position.tolist() == AT.tolist()
        assert step.feedback.vertical_speed == 0.0
        if attempt == DISARM_ATTEMPTS:
            assert step.outcome is Outcome.FCU_REJECTED and step.reason == "refused: DENIED"
            break
        assert step.outcome is None and step.command is None
        # the same refusal seen again is not another one; no new request before the pause
        t += TICK_NS
        step = land.step(observe(AT, landed=True, reply=refused), t)
        assert step.outcome is None and step.command is None
        t += DISARM_RETRY_NS
        step = land.step(observe(AT, landed=True, reply=refused), t)
        assert step.command == DISARM and step.outcome is None


def test_a_disarm_accepted_on_the_second_request_succeeds() -> None:
    land = _land(speed=0.5)
    land.step(observe(AT, landed=True), 0)
    land.step(observe(AT, landed=True, reply=_reply(DISARM, False)), TICK_NS)
    again = land.step(observe(AT, landed=True), TICK_NS + DISARM_RETRY_NS)
    assert again.command == DISARM
    step = land.step(observe(AT, landed=True, armed=False, reply=_reply(DISARM, True)),
                     2 * TICK_NS + DISARM_RETRY_NS)
    assert step.outcome is Outcome.SUCCEEDED


def test_disarmed_by_the_fcu_itself_is_a_success() -> None:
    land = _land()
    land.step(observe(AT, offboard=False), 0)
    step = land.step(observe(AT, landed=True, armed=False, reply=_reply(NAV_LAND, True)),
                     TICK_NS)
    assert step.outcome is Outcome.SUCCEEDED and step.command is None
    assert step.feedback.altitude == pytest.approx(1.0)


def test_without_disarm_touchdown_is_the_end() -> None:
    land = _land(speed=0.5, disarm=False)
    step = land.step(observe(AT, landed=True), 0)
    assert step.outcome is Outcome.SUCCEEDED and step.command is None
    assert step.setpoint is not None and step.setpoint.velocity.tolist() == [0.0, 0.0, 0.0]
    assert step.feedback.altitude == pytest.approx(1.0)


def test_no_touchdown_no_outcome() -> None:
    land = _land(speed=0.5)
    for k in range(5):
        assert land.step(observe(AT - [0, 0, 0.1 * k]), k * TICK_NS).outcome is None


@pytest.mark.parametrize("speed", [-0.1, math.nan, math.inf])
def test_a_bad_speed_is_refused(speed: float) -> None:
    with pytest.raises(ValueError, match="must be finite and >= 0"):
        _land(speed=speed)
