"""The node's own services and wiring on a scripted FCU (no MuJoCo): arming with the
command retries, the busy check, battery health at the critical level, the field bounds
that only the app may give."""

from __future__ import annotations

from typing import Any

import pytest

import interfaces
from flight_control.flight_control_node import FlightControlNode
from interfaces.px4 import CommandResult, VehicleCmd
from runtime import DeterministicExecutor, ParameterError
from tests.flight_control.rig import make_rig, reach_goal

ARM_CMD = VehicleCmd.COMPONENT_ARM_DISARM
HEALTH: Any = interfaces.get_message("quadmission_interfaces/msg/ModuleHealth")


def test_the_node_refuses_to_start_without_field_bounds_from_the_app() -> None:
    ex = DeterministicExecutor()
    with pytest.raises(ParameterError, match="the app must give field_min and field_max"):
        FlightControlNode(context=ex.context)


def test_arm_streams_asks_for_offboard_then_arms() -> None:
    rig = make_rig()
    out = rig.call("arm")
    assert out.success and out.result == out.RESULT_OK
    assert out.message == "armed in offboard at (1.0, 1.0, 0.0) m"
    mode, arm = rig.fcu.sent(VehicleCmd.DO_SET_MODE), rig.fcu.sent(ARM_CMD)
    assert len(mode) == 1 and len(arm) == 1
    assert mode[0] - 0.5 >= rig.fc.params.offboard_stream_s  # streamed first
    assert rig.fc.setpoint is not None


def test_arm_fails_when_the_fcu_acks_but_never_enters_offboard() -> None:
    rig = make_rig()
    rig.fcu.obeys_mode_changes = False
    out = rig.call("arm")
    assert not out.success
    assert out.result == out.RESULT_TIMEOUT
    assert out.message.startswith("the FCU accepted arming but was not armed in offboard")
    assert "nav_state 4" in out.message  # AUTO_LOITER
    assert rig.fc.setpoint is None  # the stream stops: nothing in control


def test_a_temporary_rejection_is_retried() -> None:
    rig = make_rig()
    rig.fcu.answers[VehicleCmd.DO_SET_MODE] = [CommandResult.TEMPORARILY_REJECTED]
    out = rig.call("arm")
    assert out.success, out.message
    sends = rig.fcu.sent(VehicleCmd.DO_SET_MODE)
    assert len(sends) == 2
    assert sends[1] - sends[0] == pytest.approx(rig.fc.params.command_timeout_s, abs=0.06)


def test_a_lost_ack_is_retried() -> None:
    rig = make_rig()
    rig.fcu.answers[ARM_CMD] = [None]
    out = rig.call("arm")
    assert out.success, out.message
    assert len(rig.fcu.sent(ARM_CMD)) == 2


def test_arm_gives_up_after_command_attempts_without_an_ack() -> None:
    rig = make_rig()
    attempts = rig.fc.params.command_attempts
    rig.fcu.answers[VehicleCmd.DO_SET_MODE] = [None] * attempts
    out = rig.call("arm", 20.0)
    assert not out.success and out.result == out.RESULT_TIMEOUT
    assert out.message == f"DO_SET_MODE: no ack from the FCU after {attempts} attempt(s)"
    assert len(rig.fcu.sent(VehicleCmd.DO_SET_MODE)) == attempts
    assert not rig.fcu.sent(ARM_CMD)
    assert rig.fc.setpoint is None  # the stream stops


def test_a_denied_arm_is_final() -> None:
    rig = make_rig()
    rig.fcu.answers[ARM_CMD] = [CommandResult.DENIED]
    out = rig.call("arm")
    assert not out.success and out.result == out.RESULT_DENIED
    assert out.fcu_result == CommandResult.DENIED
    assert len(rig.fcu.sent(ARM_CMD)) == 1


def test_arm_while_arming_is_busy() -> None:
    rig = make_rig()
    arm = rig.clients["arm"]
    first = arm.call_async(interfaces.new(arm.srv_type.Request))
    rig.ex.spin_for(0.3)  # streaming before offboard
    second = rig.wait(arm.call_async(interfaces.new(arm.srv_type.Request)), 1.0)
    assert second.result == second.RESULT_BUSY and not second.success
    assert second.message == "arming already in progress"
    assert rig.wait(first, 10.0).success
    assert len(rig.fcu.sent(ARM_CMD)) == 1
    again = rig.call("arm")
    assert again.result == again.RESULT_BUSY and again.message == "already armed"


def test_disarm() -> None:
    rig = make_rig()
    assert rig.call("disarm").message == "already disarmed"
    rig.call("arm")
    out = rig.call("disarm")
    assert out.success and out.message == "disarmed"
    assert rig.fc.setpoint is None


def _health_level(rig: object) -> tuple[int, str]:
    report = rig.health[-1]  # type: ignore[attr-defined]
    return report.level, report.modules[0].message


def test_battery_critical_exactly_at_the_configured_warning_level() -> None:
    rig = make_rig(flying_at=(2.0, 2.0, 1.5))
    critical = rig.fc.params.battery_critical_warning
    rig.fcu.battery_warning = critical - 1
    rig.ex.spin_for(1.1)
    level, message = _health_level(rig)
    assert level == HEALTH.LEVEL_WARN
    assert message == f"battery low (warning level {critical - 1})"
    assert rig.send("reach", **reach_goal(2.0, 2.5, 1.5)).accepted
    rig.fcu.battery_warning = critical
    rig.ex.spin_for(1.1)
    level, message = _health_level(rig)
    # the vehicle's state, not a fault of the module: the mission reacts to the battery on
    # its own cause, and an error here would stop (HOLD) the landing it asks for
    assert level == HEALTH.LEVEL_WARN
    assert message == f"battery critical (warning level {critical})"
    handle = rig.send("reach", **reach_goal(2.0, 3.0, 1.5))
    assert not handle.accepted
    assert rig.result(handle).result.message == f"battery critical (warning level {critical})"
    assert rig.send("land").accepted  # landing is always allowed


def test_preflight_health_is_ok_and_stale_without_status() -> None:
    rig = make_rig()
    rig.ex.spin_for(1.0)
    assert _health_level(rig) == (HEALTH.LEVEL_OK, "")
    rig.fcu.destroy_node()
    rig.ex.spin_for(2.5)
    assert _health_level(rig) == (HEALTH.LEVEL_STALE, "no /fcu/status")
