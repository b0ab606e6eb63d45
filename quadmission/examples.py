"""The example nodes of the README's "Writing a node": a talker and a listener.

``config/launch/example.yaml`` launches them (``quadmission launch
config/launch/example.yaml --duration 2``); the talker's rate comes from
``config/talker.yaml``. The listener logs each message it hears.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import interfaces
from runtime import Node, param, qos_profile_default

__all__ = ["Listener", "Talker", "TalkerParams"]


@dataclass(frozen=True)
class TalkerParams:
    rate_hz: float = param(unit="Hz", range=(0.1, 1000.0), description="publish rate")


class Talker(Node):
    """Publishes ``hello <n>`` on ``chatter`` at ``rate_hz``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("talker", **kwargs)
        self.params = self.declare_params(TalkerParams)
        self.pub = self.create_publisher("std_msgs/msg/String", "chatter", qos_profile_default)
        self.count = 0
        self.create_timer(1.0 / self.params.rate_hz, self.tick)

    def tick(self) -> None:
        self.count += 1
        self.pub.publish(interfaces.new("std_msgs/msg/String", data=f"hello {self.count}"))


class Listener(Node):
    """Keeps and logs every message on ``chatter``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("listener", **kwargs)
        self.heard: list[str] = []
        self.create_subscription("std_msgs/msg/String", "chatter", self.on_message,
                                 qos_profile_default)

    def on_message(self, msg: Any) -> None:
        self.heard.append(msg.data)
        self.get_logger().info(f"heard {msg.data!r}")
