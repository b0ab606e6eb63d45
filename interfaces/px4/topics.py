"""The /fmu topics of the PX4 contract: names, px4_msgs types and QoS, written once.

The simulated firmware's uXRCE-DDS agent publishes :data:`FMU_OUT` and subscribes to
:data:`FMU_IN` with the PX4 side's QoS; the companion bridge does the opposite with
:data:`COMPANION_PUBLISHER_QOS` and :data:`COMPANION_SUBSCRIBER_QOS` (seed 000's list:
best effort, keep last; PX4's publishers are transient local).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from interfaces.qos import (
    QoSProfile,
    qos_profile_px4_in,
    qos_profile_px4_out,
    qos_profile_px4_subscriber,
)

__all__ = [
    "COMPANION_PUBLISHER_QOS",
    "COMPANION_SUBSCRIBER_QOS",
    "FMU_IN",
    "FMU_OUT",
    "XRCE_TIMESYNC_BYTES",
    "FmuTopic",
]


@dataclass(frozen=True)
class FmuTopic:
    """One /fmu topic: its full name, its px4_msgs type and the FCU side's QoS."""

    name: str
    type: str
    qos: QoSProfile

    @property
    def short(self) -> str:
        """The name without ``/fmu/in/`` or ``/fmu/out/``."""
        return self.name.rsplit("/", 1)[1]


def _table(prefix: str, qos: QoSProfile, types: dict[str, str]) -> Mapping[str, FmuTopic]:
    return MappingProxyType({short: FmuTopic(f"{prefix}/{short}", f"px4_msgs/msg/{t}", qos)
                             for short, t in types.items()})


#: FCU -> companion, keyed by short name (rates are the firmware's module table).
FMU_OUT: Mapping[str, FmuTopic] = _table("/fmu/out", qos_profile_px4_out, {
    "vehicle_odometry": "VehicleOdometry",
    "vehicle_local_position": "VehicleLocalPosition",
    "vehicle_attitude": "VehicleAttitude",
    "vehicle_status": "VehicleStatus",
    "battery_status": "BatteryStatus",
    "timesync_status": "TimesyncStatus",
    "vehicle_command_ack": "VehicleCommandAck",
    "vehicle_land_detected": "VehicleLandDetected",
    "failsafe_flags": "FailsafeFlags",
    "sensor_combined": "SensorCombined",
    "timesync": "Timesync",
})
#: companion -> FCU, keyed by short name.
FMU_IN: Mapping[str, FmuTopic] = _table("/fmu/in", qos_profile_px4_in, {
    "offboard_control_mode": "OffboardControlMode",
    "trajectory_setpoint": "TrajectorySetpoint",
    "vehicle_command": "VehicleCommand",
    "vehicle_visual_odometry": "VehicleOdometry",
    "timesync": "Timesync",
})
#: What a companion node publishes /fmu/in with.
COMPANION_PUBLISHER_QOS = qos_profile_px4_in
#: What a companion node reads /fmu/out with (PX4's guide: sensor data, depth 5).
COMPANION_SUBSCRIBER_QOS = qos_profile_px4_subscriber
#: CDR size of the XRCE time-sync request/reply the agent answers (header + 3 stamps) [bytes].
XRCE_TIMESYNC_BYTES = 32
