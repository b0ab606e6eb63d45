"""A publisher: one message type on one topic (rclpy's ``Publisher``)."""

from __future__ import annotations

from typing import Any, Generic, TypeVar

from interfaces.qos import QoSProfile
from runtime.entity import EntityNode, sender, type_name_of
from runtime.errors import TopicTypeError
from runtime.transport import Endpoint

__all__ = ["Publisher"]

T = TypeVar("T")


class Publisher(Generic[T]):
    """Publishes one message type on one topic."""

    def __init__(self, node: EntityNode, msg_type: type | str, topic: str, qos: QoSProfile) -> None:
        self.msg_type = msg_type
        self.type_name = type_name_of(msg_type)
        self.topic_name = node.resolve_name(topic)
        self.qos_profile = qos
        self._node = node
        self._writer = node.context.transport.create_writer(
            Endpoint(self.topic_name, self.type_name, qos, node=node.get_fully_qualified_name()))
        self._send = sender(self._writer, self.type_name)

    def publish(self, msg: Any) -> None:
        """Validate and send ``msg``; MessageError names a malformed field.

        ``msg`` may also be the CDR bytes of a message of this topic's type, already
        serialized (as rclpy publishes a serialized message): they are sent as they are.
        In one process the subscribers receive ``msg`` itself: do not change it afterwards.
        """
        if isinstance(msg, bytes):
            self._writer.write(msg)
            return
        actual = getattr(msg, "__msgtype__", type(msg).__name__)
        if actual != self.type_name:
            raise TopicTypeError(
                f"publish on {self.topic_name}: expected {self.type_name}, got {actual}"
            )
        self._send(msg, None)

    def get_subscription_count(self) -> int:
        return self._writer.matched_count()

    def destroy(self) -> None:
        self._writer.close()

