"""Live topics to Foxglove over foxglove-sdk's WebSocket server.

Every discovered topic becomes a channel with the ``ros2msg`` schema of its type (from
our typestore) and ``cdr`` messages, exactly as a rosbag2 MCAP holds them, so Foxglove
decodes them without our code: open Foxglove, "Open connection", Foxglove WebSocket,
``ws://127.0.0.1:8765``. The server binds to loopback unless ``host`` says otherwise.
"""

from __future__ import annotations

from typing import Any

import foxglove
from foxglove import Channel, Schema

from ground_station.bag import message_definition
from ground_station.params import FoxgloveBridgeParams
from ground_station.topic_tap import TopicTap
from runtime import Node

NODE_NAME = "foxglove_bridge"


class FoxgloveBridgeNode(Node):
    """Serves the topics it discovers on ``ws://host:port`` (``self.port`` once started)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(FoxgloveBridgeParams)
        self._context = foxglove.Context()
        self.server = foxglove.start_server(name="quadmission", host=self.params.host,
                                            port=self.params.port, context=self._context)
        self.host = self.params.host
        self.port = self.server.port
        self.channels: dict[str, Channel] = {}
        try:
            self.tap = TopicTap(self, include=self.params.include, exclude=self.params.exclude,
                                discovery_period_s=self.params.discovery_period_s,
                                on_new_topic=self._on_new_topic, on_sample=self._on_sample)
        except BaseException:
            self.server.stop()  # a refused pattern does not keep the port bound
            raise
        self.get_logger().info("Foxglove: open connection %s", self.url)

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def _on_new_topic(self, topic: str, msgtype: str) -> Channel:
        msgdef = message_definition(msgtype)
        channel = Channel(topic, message_encoding="cdr", context=self._context,
                          schema=Schema(name=msgtype, encoding="ros2msg",
                                        data=msgdef.encode()))
        self.channels[topic] = channel
        return channel

    @staticmethod
    def _on_sample(channel: Channel, t_ns: int, data: bytes) -> None:
        if channel.has_sinks():
            channel.log(data, log_time=t_ns)

    def close(self) -> None:
        self.tap.close()
        for channel in self.channels.values():
            channel.close()
        self.server.stop()

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()


__all__ = ["NODE_NAME", "FoxgloveBridgeNode"]
