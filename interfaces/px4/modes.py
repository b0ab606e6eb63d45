"""PX4 numbers that are in no .msg file: the custom modes of DO_SET_MODE and the MAVLink flags
it takes, the MAVLink vehicle type, the odometry quality scale and the MAVLink system and
component ids of the FCU and the companion, written once here (PX4
``src/modules/commander/px4_custom_mode.h``, MAVLink ``MAV_MODE_FLAG``,
``MAV_CMD_COMPONENT_ARM_DISARM``, ``MAV_TYPE``, ``ODOMETRY.quality``, ``MAV_COMPONENT`` and
PX4's ``MAV_SYS_ID`` / ``MAV_COMP_ID`` defaults)."""

from enum import IntEnum

__all__ = ["BROADCAST_ID", "COMPANION_COMPONENT_ID", "FCU_COMPONENT_ID", "FCU_SYSTEM_ID",
           "FORCE_ARM_DISARM_MAGIC", "MAV_MODE_FLAG_CUSTOM_MODE_ENABLED", "MAV_TYPE_QUADROTOR",
           "ODOMETRY_QUALITY_BEST", "Px4CustomMainMode", "Px4CustomSubModeAuto"]

#: COMPONENT_ARM_DISARM ``param2`` that skips the arming and disarming checks.
FORCE_ARM_DISARM_MAGIC = 21196
#: DO_SET_MODE ``param1``: ``param2``/``param3`` carry PX4's custom main and sub mode.
MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1
#: MAVLink ``MAV_TYPE_QUADROTOR``: ``VehicleStatus.system_type`` carries a MAV_TYPE.
MAV_TYPE_QUADROTOR = 2
#: ``VehicleOdometry.quality`` at its best: MAVLink ``ODOMETRY.quality`` is a percentage
#: (-1 failed, 0 unknown, 1 worst .. 100 best); the .msg says only "0 if invalid".
ODOMETRY_QUALITY_BEST = 100

#: The vehicle's MAVLink system id: PX4's ``MAV_SYS_ID`` default. The companion computer is
#: a component of the same system, so it sends with this system id too.
FCU_SYSTEM_ID = 1
#: The flight controller's component id: ``MAV_COMP_ID_AUTOPILOT1`` (PX4's ``MAV_COMP_ID``).
FCU_COMPONENT_ID = 1
#: The companion's component id: ``MAV_COMP_ID_ONBOARD_COMPUTER``.
COMPANION_COMPONENT_ID = 191
#: A target system or component of 0 addresses every system or component.
BROADCAST_ID = 0


class Px4CustomMainMode(IntEnum):
    """``PX4_CUSTOM_MAIN_MODE_*`` (DO_SET_MODE ``param2``)."""

    MANUAL = 1
    ALTCTL = 2
    POSCTL = 3
    AUTO = 4
    ACRO = 5
    OFFBOARD = 6
    STABILIZED = 7


class Px4CustomSubModeAuto(IntEnum):
    """``PX4_CUSTOM_SUB_MODE_AUTO_*`` (DO_SET_MODE ``param3`` with main mode AUTO)."""

    READY = 1
    TAKEOFF = 2
    LOITER = 3
    MISSION = 4
    RTL = 5
    LAND = 6
    FOLLOW_TARGET = 8
    PRECLAND = 9
