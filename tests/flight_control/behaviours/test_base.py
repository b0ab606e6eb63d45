"""What the behaviours share: observations, hold setpoints, the commands they ask for."""

from __future__ import annotations

import numpy as np

from flight_control.behaviours import DISARM, NAV_LAND, OFFBOARD, Setpoint, arm_disarm
from flight_control.behaviours.base import elapsed_s
from interfaces.px4 import (
    FORCE_ARM_DISARM_MAGIC,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    Px4CustomMainMode,
    VehicleCmd,
)
from tests.flight_control.behaviours.observe import observe


def test_in_control_means_armed_and_offboard_with_a_fresh_status() -> None:
    assert observe().in_control
    assert not observe(offboard=False).in_control
    assert not observe(armed=False).in_control
    assert not observe(stale=True).in_control
    assert observe(landed=True).landed and not observe().landed
    assert not observe(stale=True).landed and not observe(stale=True).armed
    assert observe().armed and not observe(armed=False).armed


def test_hold_is_still_and_copies_the_position() -> None:
    p = np.array([1.0, 2.0, 3.0])
    sp = Setpoint.hold(p, 0.5)
    p[0] = 9.0
    assert sp.position.tolist() == [1.0, 2.0, 3.0]
    assert Setpoint.hold(np.array([1, 2, 3]), 0).position.dtype == np.float64
    assert sp.velocity.tolist() == [0.0, 0.0, 0.0] and sp.yaw == 0.5


def test_commands_carry_px4_numbers_from_the_contract() -> None:
    assert OFFBOARD.command is VehicleCmd.DO_SET_MODE
    assert (OFFBOARD.param1, OFFBOARD.param2) == (MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                                  Px4CustomMainMode.OFFBOARD)
    assert NAV_LAND.command is VehicleCmd.NAV_LAND
    assert (DISARM.command, DISARM.param1, DISARM.param2) == (
        VehicleCmd.COMPONENT_ARM_DISARM, 0.0, 0.0)
    arm = arm_disarm(True, force=True)
    assert (arm.command, arm.param1, arm.param2) == (
        VehicleCmd.COMPONENT_ARM_DISARM, 1.0, FORCE_ARM_DISARM_MAGIC)
    assert arm_disarm(False, force=True).param1 == 0.0
    assert arm_disarm(True).param2 == 0.0


def test_elapsed_is_zero_first_and_never_negative() -> None:
    assert elapsed_s(None, 5) == 0.0
    assert elapsed_s(1_000_000_000, 3_500_000_000) == 2.5
    assert elapsed_s(2_000, 1_000) == 0.0
