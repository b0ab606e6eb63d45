"""PX4 numbers that are in no .msg file: the custom modes of DO_SET_MODE and the MAVLink flags
it takes, written once here (PX4 ``src/modules/commander/px4_custom_mode.h``, MAVLink
``MAV_MODE_FLAG`` and ``MAV_CMD_COMPONENT_ARM_DISARM``)."""

from enum import IntEnum

__all__ = ["FORCE_ARM_DISARM_MAGIC", "MAV_MODE_FLAG_CUSTOM_MODE_ENABLED", "Px4CustomMainMode",
           "Px4CustomSubModeAuto"]

#: COMPONENT_ARM_DISARM ``param2`` that skips the arming and disarming checks.
FORCE_ARM_DISARM_MAGIC = 21196
#: DO_SET_MODE ``param1``: ``param2``/``param3`` carry PX4's custom main and sub mode.
MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1


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
