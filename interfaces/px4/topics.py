"""The /fmu topics of the PX4 contract: names, px4_msgs types and QoS, written once.

Names are PX4 v1.17.0's (``src/modules/uxrce_dds_client/dds_topics.yaml``), and, as the
uXRCE-DDS client does it, a message whose ``MESSAGE_VERSION`` is above 0 gets the suffix
``_v<MESSAGE_VERSION>`` (``/fmu/out/vehicle_status_v1``); the version is read from the .msg
file, never retyped. The tables are keyed by the unversioned short name.

The Timesync exchange is not a PX4 topic (PX4 has had none since v1.14: the XRCE-DDS
session syncs the clocks itself and reports on ``/fmu/out/timesync_status``). It models
that session exchange under :data:`XRCE_SESSION`, on names outside ``/fmu``.

The simulated firmware's uXRCE-DDS agent publishes :data:`FMU_OUT` and subscribes to
:data:`FMU_IN` with the PX4 side's QoS; the companion bridge does the opposite with
:data:`COMPANION_PUBLISHER_QOS` and :data:`COMPANION_SUBSCRIBER_QOS` (seed 000's list:
best effort, keep last; PX4's publishers are transient local). The nodes that keep a
different profile on the /fmu side have it here too, each saying why:
:data:`FCU_BRIDGE_QOS` (and its lazy and ack variants), :data:`LATENCY_TEST_PUBLISHER_QOS`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType

import interfaces
from interfaces.qos import (
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_px4_in,
    qos_profile_px4_out,
    qos_profile_px4_subscriber,
)

__all__ = [
    "COMPANION_PUBLISHER_QOS",
    "COMPANION_SUBSCRIBER_QOS",
    "FCU_BRIDGE_ACK_QOS",
    "FCU_BRIDGE_LAZY_QOS",
    "FCU_BRIDGE_QOS",
    "FMU_IN",
    "FMU_OUT",
    "LATENCY_TEST_PUBLISHER_QOS",
    "XRCE_SESSION",
    "XRCE_TIMESYNC_BYTES",
    "FmuTopic",
    "versioned_name",
]


@dataclass(frozen=True)
class FmuTopic:
    """One /fmu topic: its full name, its px4_msgs type and the FCU side's QoS."""

    name: str
    type: str
    qos: QoSProfile


def versioned_name(name: str, type_name: str) -> str:
    """``name`` with PX4's ``_v<N>`` suffix when the type's MESSAGE_VERSION N is above 0."""
    version = int(getattr(interfaces.get_message(type_name), "MESSAGE_VERSION", 0))
    return f"{name}_v{version}" if version > 0 else name


def _table(prefix: str, qos: QoSProfile, types: dict[str, str]) -> Mapping[str, FmuTopic]:
    out = {}
    for short, t in types.items():
        type_name = f"px4_msgs/msg/{t}"
        out[short] = FmuTopic(versioned_name(f"{prefix}/{short}", type_name), type_name, qos)
    return MappingProxyType(out)


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
})
#: companion -> FCU, keyed by short name.
FMU_IN: Mapping[str, FmuTopic] = _table("/fmu/in", qos_profile_px4_in, {
    "offboard_control_mode": "OffboardControlMode",
    "trajectory_setpoint": "TrajectorySetpoint",
    "vehicle_command": "VehicleCommand",
    "vehicle_visual_odometry": "VehicleOdometry",
})
_TIMESYNC = "quadmission_interfaces/msg/Timesync"
#: The modelled XRCE-DDS session time sync (not PX4 topics): "request" companion -> FCU
#: (the FCU side subscribes with PX4's /fmu/in QoS), "reply" FCU -> companion.
XRCE_SESSION: Mapping[str, FmuTopic] = MappingProxyType({
    "request": FmuTopic("/xrce_session/timesync_request", _TIMESYNC, qos_profile_px4_in),
    "reply": FmuTopic("/xrce_session/timesync_reply", _TIMESYNC, qos_profile_px4_out),
})
#: What a companion node publishes /fmu/in with.
COMPANION_PUBLISHER_QOS = qos_profile_px4_in
#: What a companion node reads /fmu/out with (PX4's guide: sensor data, depth 5).
COMPANION_SUBSCRIBER_QOS = qos_profile_px4_subscriber
#: The FCU bridge's /fmu QoS, both directions (and the session's time sync): seed 000's
#: measured setting (section 3.1): best effort, transient local, keep last 1. Unlike the
#: companion default it queues only the newest sample (a control loop wants nothing
#: older), and a late subscriber still gets the last one. It matches PX4's uXRCE-DDS
#: publishers and subscribers.
FCU_BRIDGE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT,
                            durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: The bridge's lazy subscription (/fmu/out/sensor_combined while /fcu/imu has readers):
#: as :data:`FCU_BRIDGE_QOS`, volatile: a sample the agent kept from an earlier reader
#: would be stale.
FCU_BRIDGE_LAZY_QOS = replace(FCU_BRIDGE_QOS, durability=DurabilityPolicy.VOLATILE)
#: The bridge's /fmu/out/vehicle_command_ack reader: as :data:`FCU_BRIDGE_QOS`, keep last
#: 10: acks are events, not state, and two in one instant must both arrive.
FCU_BRIDGE_ACK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT,
                                durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Seed 000's latency test's writers (/fmu/in/vehicle_visual_odometry, the session's
#: time-sync request): best effort, volatile, keep last 1, as the paper measured (section
#: 3.1: one message in the queue); the companion default's 5 would let a sample wait
#: behind older ones and add that wait to the measured latency.
LATENCY_TEST_PUBLISHER_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
#: CDR size of the XRCE time-sync request/reply the agent answers (header + 3 stamps) [bytes].
XRCE_TIMESYNC_BYTES = 32
