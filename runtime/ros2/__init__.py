"""The ROS 2 transport: every node a real rcl node on rclpy (Fast DDS), messages as CDR."""

from runtime.ros2.config import Ros2Config
from runtime.ros2.transport import Ros2Transport

__all__ = ["Ros2Config", "Ros2Transport"]
