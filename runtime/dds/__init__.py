"""The Cyclone DDS transport: ROS 2 wire conventions over the cyclonedds wheel."""

from runtime.dds.config import DdsConfig
from runtime.dds.transport import DdsTransport

__all__ = ["DdsConfig", "DdsTransport"]
