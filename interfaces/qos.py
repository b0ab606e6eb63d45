"""Quality of service profiles, with the presets ROS 2 and PX4 use."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


class ReliabilityPolicy(Enum):
    RELIABLE = "reliable"
    BEST_EFFORT = "best_effort"


class DurabilityPolicy(Enum):
    VOLATILE = "volatile"
    TRANSIENT_LOCAL = "transient_local"


class HistoryPolicy(Enum):
    KEEP_LAST = "keep_last"
    KEEP_ALL = "keep_all"


@dataclass(frozen=True)
class QoSProfile:
    """Reliability, durability and history of one endpoint.

    ``depth`` bounds the reader's queue under KEEP_LAST (the oldest sample is dropped) and
    the writer's stored history under TRANSIENT_LOCAL (what a late joiner receives).
    """

    depth: int = 10
    history: HistoryPolicy = HistoryPolicy.KEEP_LAST
    reliability: ReliabilityPolicy = ReliabilityPolicy.RELIABLE
    durability: DurabilityPolicy = DurabilityPolicy.VOLATILE

    def __post_init__(self) -> None:
        if self.history is HistoryPolicy.KEEP_LAST and self.depth < 1:
            raise ValueError(f"QoS depth must be >= 1 with KEEP_LAST, got {self.depth}")

    def incompatibility(self, offered: QoSProfile) -> str | None:
        """Why a reader with this profile cannot match a writer offering ``offered``.

        The DDS request/offer rules: a RELIABLE reader needs a RELIABLE writer, a
        TRANSIENT_LOCAL reader needs a TRANSIENT_LOCAL writer. None when they match.
        """
        if (
            self.reliability is ReliabilityPolicy.RELIABLE
            and offered.reliability is ReliabilityPolicy.BEST_EFFORT
        ):
            return "reader requests RELIABLE but writer offers BEST_EFFORT"
        if (
            self.durability is DurabilityPolicy.TRANSIENT_LOCAL
            and offered.durability is DurabilityPolicy.VOLATILE
        ):
            return "reader requests TRANSIENT_LOCAL but writer offers VOLATILE"
        return None


#: ROS 2 default for topics: reliable, volatile, keep last 10.
qos_profile_default = QoSProfile()
#: ROS 2 sensor data: best effort, volatile, keep last 5.
qos_profile_sensor_data = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
#: ROS 2 services: reliable, volatile, keep last 10.
qos_profile_services_default = QoSProfile()
#: ROS 2 action status: reliable, transient local, keep last 1.
qos_profile_action_status_default = QoSProfile(
    depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
#: Latched state (a map, a mission sequence): reliable, transient local, keep last 1.
qos_profile_latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: PX4 uXRCE-DDS publishers (/fmu/out/*): best effort, transient local, keep last.
qos_profile_px4_out = QoSProfile(
    depth=5,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
#: PX4 uXRCE-DDS subscribers (/fmu/in/*): best effort, volatile, keep last.
qos_profile_px4_in = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
#: What a companion node uses to read /fmu/out/* (PX4's guide: sensor data, depth 5).
qos_profile_px4_subscriber = qos_profile_sensor_data

PRESETS: dict[str, QoSProfile] = {
    "default": qos_profile_default,
    "sensor_data": qos_profile_sensor_data,
    "services_default": qos_profile_services_default,
    "action_status_default": qos_profile_action_status_default,
    "latched": qos_profile_latched,
    "px4_out": qos_profile_px4_out,
    "px4_in": qos_profile_px4_in,
}


def as_qos(qos: QoSProfile | int) -> QoSProfile:
    """rclpy accepts a bare depth for a default profile; so do we."""
    if isinstance(qos, QoSProfile):
        return qos
    if isinstance(qos, bool) or not isinstance(qos, int):
        raise TypeError(f"QoS must be a QoSProfile or a history depth, got {qos!r}")
    return QoSProfile(depth=qos)
