"""Domain id and discovery range of a ROS 2 process, as the environment rmw reads.

By default nothing leaves the machine: Jazzy's ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``
(Fast DDS then discovers and talks over loopback and shared memory only). The wheels' Fast
DDS has no security plugins, so this is the boundary. ``localhost_only=False`` opens it to
the subnet (``SUBNET``, Jazzy's default), for a ROS 2 machine on the LAN.

Fast DDS reads its participant from :data:`FASTDDS_PROFILE` (``fastdds_profile.xml``):
the built-in transports with shared-memory segments large enough for camera images. A
profile the user names in ``FASTRTPS_DEFAULT_PROFILES_FILE`` is left in charge.
"""

from __future__ import annotations

import importlib.util
import os
from dataclasses import dataclass
from pathlib import Path

__all__ = ["DEFAULT_DOMAIN_ID", "FASTDDS_PROFILE", "REQUIRED_MODULES", "RMW_IMPLEMENTATION",
           "Ros2Config", "missing_modules"]

DEFAULT_DOMAIN_ID = 0
RMW_IMPLEMENTATION = "rmw_fastrtps_cpp"  # the one the wheels ship (ros-jazzy-rclpy[fastrtps])
#: Fast DDS's default participant profile for our processes (16 MiB shared-memory segments)
FASTDDS_PROFILE = Path(__file__).with_name("fastdds_profile.xml")
_PROFILE_VARIABLE = "FASTRTPS_DEFAULT_PROFILES_FILE"  # the name Fast DDS 2.14 reads
#: What the transport imports: rclpy (the ``ros2`` extra) and our interface packages (built
#: into the venv by ``make``'s set-up, tools/build_ros_interfaces.py)
REQUIRED_MODULES = ("rclpy", "px4_msgs", "quadmission_interfaces")
SETUP_HINT = "run `make` (it installs ROS 2 Jazzy and builds our interface packages)"


def missing_modules() -> list[str]:
    """The modules of :data:`REQUIRED_MODULES` this interpreter cannot import."""
    return [m for m in REQUIRED_MODULES if importlib.util.find_spec(m) is None]


@dataclass(frozen=True)
class Ros2Config:
    """Domain id and network scope of a process's rclpy context."""

    domain_id: int = DEFAULT_DOMAIN_ID
    localhost_only: bool = True

    def __post_init__(self) -> None:
        if not 0 <= self.domain_id <= 232:
            raise ValueError(f"ROS 2 domain id {self.domain_id} is outside 0..232")

    def environment(self) -> dict[str, str]:
        """The variables rmw reads when the context starts (set before ``rclpy.init``)."""
        return {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST" if self.localhost_only
                else "SUBNET",
                "ROS_DOMAIN_ID": str(self.domain_id),
                "RMW_IMPLEMENTATION": RMW_IMPLEMENTATION}

    def apply(self) -> None:
        """Put :meth:`environment` into this process's environment; drop the deprecated
        ``ROS_LOCALHOST_ONLY``, which would override the range; name our Fast DDS profile
        unless the user named one."""
        os.environ.pop("ROS_LOCALHOST_ONLY", None)
        os.environ.update(self.environment())
        os.environ.setdefault(_PROFILE_VARIABLE, str(FASTDDS_PROFILE))
