"""The Cyclone DDS configuration the transport runs with, generated.

By default everything stays on this machine: the loopback interface only, no multicast,
discovery by unicast to the well-known ports of participant indices 0..N on 127.0.0.1
(so a process that joins later, a ``cyclonedds`` CLI among them, finds the others). A
caller that wants the network (a ROS 2 machine on the LAN) asks for it with
``loopback_only=False``: Cyclone's own defaults (every suitable interface, multicast
discovery) then apply.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DEFAULT_DOMAIN_ID", "DdsConfig"]

DEFAULT_DOMAIN_ID = 0
_MAX_LOCAL_PARTICIPANTS = 40  # participant indices probed on 127.0.0.1


@dataclass(frozen=True)
class DdsConfig:
    """Domain id and network scope of a participant."""

    domain_id: int = DEFAULT_DOMAIN_ID
    loopback_only: bool = True

    def __post_init__(self) -> None:
        if not 0 <= self.domain_id <= 232:
            raise ValueError(f"DDS domain id {self.domain_id} is outside 0..232")

    def xml(self) -> str:
        """The CYCLONEDDS_URI text for this configuration."""
        if not self.loopback_only:
            return "<CycloneDDS><Domain Id=\"any\"/></CycloneDDS>"
        return (
            "<CycloneDDS><Domain Id=\"any\">"
            "<General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>"
            "<AllowMulticast>false</AllowMulticast></General>"
            "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
            f"<MaxAutoParticipantIndex>{_MAX_LOCAL_PARTICIPANTS}</MaxAutoParticipantIndex>"
            "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery>"
            "</Domain></CycloneDDS>"
        )
