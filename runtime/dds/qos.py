"""Our QoS profiles as Cyclone DDS QoS, one to one, and DDS policy ids as names."""

from __future__ import annotations

from cyclonedds.core import Policy
from cyclonedds.qos import Qos

from interfaces.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ["POLICY_NAMES", "dds_qos"]

#: DDS QosPolicyId_t -> name (the ids Cyclone reports in incompatible-QoS statuses).
POLICY_NAMES = {
    2: "DURABILITY", 4: "DEADLINE", 5: "LATENCY_BUDGET", 6: "OWNERSHIP", 8: "LIVELINESS",
    11: "RELIABILITY", 12: "DESTINATION_ORDER", 13: "HISTORY", 14: "RESOURCE_LIMITS",
    23: "DATA_REPRESENTATION", 24: "TYPE_CONSISTENCY",
}
_MAX_BLOCKING_NS = 100_000_000  # reliable writer blocks at most this long (rmw's default)


def dds_qos(profile: QoSProfile, user_data: bytes | None = None) -> Qos:
    """Reliability, durability and history as DDS policies; XCDR1 representation (what
    ROS 2 Jazzy endpoints use); ``user_data`` (the ``typehash=...;`` string) if given."""
    policies = [
        Policy.Reliability.Reliable(_MAX_BLOCKING_NS)
        if profile.reliability is ReliabilityPolicy.RELIABLE
        else Policy.Reliability.BestEffort,
        Policy.Durability.TransientLocal
        if profile.durability is DurabilityPolicy.TRANSIENT_LOCAL
        else Policy.Durability.Volatile,
        Policy.History.KeepLast(profile.depth)
        if profile.history is HistoryPolicy.KEEP_LAST
        else Policy.History.KeepAll,
        Policy.DataRepresentation(use_cdrv0_representation=True),
    ]
    if user_data is not None:
        policies.append(Policy.Userdata(user_data))
    return Qos(*policies)
