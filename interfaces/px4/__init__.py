"""The PX4 contract both sides of the link share: enums read from the px4_msgs .msg files,
the /fmu topics (names, types, QoS), PX4's time-sync filter and exchange, and seed 000's
measured link figures. A leaf above interfaces/: the firmware and the bridge import it."""

from interfaces.px4.constants import (
    ArmDisarmReason,
    ArmingState,
    BatteryWarning,
    CommandResult,
    NavigationState,
    PoseFrame,
    TimesyncSource,
    VehicleCmd,
    VehicleType,
    VelocityFrame,
)
from interfaces.px4.modes import (
    BROADCAST_ID,
    COMPANION_COMPONENT_ID,
    FCU_COMPONENT_ID,
    FCU_SYSTEM_ID,
    FORCE_ARM_DISARM_MAGIC,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_TYPE_QUADROTOR,
    ODOMETRY_QUALITY_BEST,
    Px4CustomMainMode,
    Px4CustomSubModeAuto,
)
from interfaces.px4.topics import FMU_IN, FMU_OUT, FmuTopic

__all__ = [
    "BROADCAST_ID",
    "COMPANION_COMPONENT_ID",
    "FCU_COMPONENT_ID",
    "FCU_SYSTEM_ID",
    "FMU_IN",
    "FMU_OUT",
    "FORCE_ARM_DISARM_MAGIC",
    "MAV_MODE_FLAG_CUSTOM_MODE_ENABLED",
    "MAV_TYPE_QUADROTOR",
    "ODOMETRY_QUALITY_BEST",
    "ArmDisarmReason",
    "ArmingState",
    "BatteryWarning",
    "CommandResult",
    "FmuTopic",
    "NavigationState",
    "PoseFrame",
    "Px4CustomMainMode",
    "Px4CustomSubModeAuto",
    "TimesyncSource",
    "VehicleCmd",
    "VehicleType",
    "VelocityFrame",
]
