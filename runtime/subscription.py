"""A subscription: a callback per message of one topic (rclpy's ``Subscription``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Generic, TypeVar

import interfaces
from interfaces.qos import QoSProfile
from runtime.entity import EntityNode, Inbox, sample_bytes, sample_message, type_name_of
from runtime.transport import Endpoint, RequestId, Sample

__all__ = ["Subscription"]

T = TypeVar("T")


class Subscription(Generic[T]):
    """Calls ``callback(msg)`` for each message, in arrival order, on the executor."""

    def __init__(
        self,
        node: EntityNode,
        msg_type: type | str,
        topic: str,
        callback: Callable[[Any], None],
        qos: QoSProfile,
        raw: bool = False,
    ) -> None:
        self.msg_type = msg_type
        self.type_name = type_name_of(msg_type)
        self.topic_name = node.resolve_name(topic)
        self.qos_profile = qos
        self.callback = callback
        self.raw = raw
        self.malformed = 0
        self._node = node
        self._inbox = Inbox(node, qos, (node.get_name(), "subscription", self.topic_name),
                             self._handle)
        self._reader = node.context.transport.create_reader(
            Endpoint(self.topic_name, self.type_name, qos, node=node.get_fully_qualified_name()),
            self._inbox.on_sample)

    @property
    def dropped(self) -> int:
        """Samples dropped because the KEEP_LAST queue was full."""
        return self._inbox.dropped

    def _handle(self, data: Sample, _request_id: RequestId | None) -> None:
        if self.raw:
            self.callback(sample_bytes(data, self.type_name))
            return
        try:
            msg = sample_message(data, self.type_name)
        except interfaces.MessageError as exc:
            self.malformed += 1
            self._node.get_logger().error(f"dropped a malformed sample on {self.topic_name}: {exc}")
            return
        self.callback(msg)

    def get_publisher_count(self) -> int:
        return self._reader.matched_count()

    def destroy(self) -> None:
        self._inbox.closed = True
        self._reader.close()

