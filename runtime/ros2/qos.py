"""Our QoS profiles as rclpy's, one to one."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy as RclDurability
from rclpy.qos import HistoryPolicy as RclHistory
from rclpy.qos import QoSProfile as RclQoSProfile
from rclpy.qos import ReliabilityPolicy as RclReliability

from interfaces.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ["rclpy_qos"]

_RELIABILITY = {ReliabilityPolicy.RELIABLE: RclReliability.RELIABLE,
                ReliabilityPolicy.BEST_EFFORT: RclReliability.BEST_EFFORT}
_DURABILITY = {DurabilityPolicy.VOLATILE: RclDurability.VOLATILE,
               DurabilityPolicy.TRANSIENT_LOCAL: RclDurability.TRANSIENT_LOCAL}
_HISTORY = {HistoryPolicy.KEEP_LAST: RclHistory.KEEP_LAST,
            HistoryPolicy.KEEP_ALL: RclHistory.KEEP_ALL}


def rclpy_qos(profile: QoSProfile) -> RclQoSProfile:
    """Reliability, durability, history and depth as an rclpy profile."""
    return RclQoSProfile(reliability=_RELIABILITY[profile.reliability],
                         durability=_DURABILITY[profile.durability],
                         history=_HISTORY[profile.history], depth=profile.depth)
