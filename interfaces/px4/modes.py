"""PX4 numbers that are in no .msg file: the custom modes of DO_SET_MODE and the MAVLink flags
it takes, the MAVLink vehicle type and the odometry quality scale, written once here (PX4
``src/modules/commander/px4_custom_mode.h``, MAVLink ``MAV_MODE_FLAG``,
``MAV_CMD_COMPONENT_ARM_DISARM``, ``MAV_TYPE`` and ``ODOMETRY.quality``)."""

from enum import IntEnum

__all__ = ["FORCE_ARM_DISARM_MAGIC", "MAV_MODE_FLAG_CUSTOM_MODE_ENABLED", "MAV_TYPE_QUADROTOR",
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
