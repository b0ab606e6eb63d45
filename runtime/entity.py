"""What a node's entities share: the node they belong to, and how they meet the transport.

Entities talk only through their context's transport. A message published is validated;
over a transport that crosses processes it is serialized and each subscriber gets its own
deserialized copy; in one process (a :class:`~runtime.transport.MessageWriter`) the
subscribers share the published object, which nobody may change after publishing or
receiving it. Every message stays CDR-serialisable, so any node can move to another
process unchanged.

An entity knows its node only as an :class:`EntityNode` (what it uses of
:class:`runtime.node.Node`), as rclpy's entities do not import the node that makes them.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any, Protocol

import interfaces
from interfaces.qos import HistoryPolicy, QoSProfile
from runtime.context import Context
from runtime.logger import NodeLogger
from runtime.loop import Label
from runtime.transport import MessageWriter, RequestId, Sample, Writer

__all__ = ["EntityNode", "Inbox", "sample_bytes", "sample_message", "sender", "type_name_of"]


class EntityNode(Protocol):
    """What an entity uses of the node that makes it (:class:`runtime.node.Node`)."""

    @property
    def context(self) -> Context[Any]: ...

    def get_name(self) -> str: ...

    def get_fully_qualified_name(self) -> str: ...

    def get_logger(self) -> NodeLogger: ...

    def resolve_name(self, name: str) -> str: ...

    def next_guid(self, kind: str, name: str) -> int: ...


def type_name_of(msg_type: type | str) -> str:
    if isinstance(msg_type, str):  # UnknownTypeError for a bad name
        return interfaces.type_name(interfaces.get_message(msg_type))
    return interfaces.type_name(msg_type)


def sender(writer: Writer, type_name: str) -> Callable[[Any, RequestId | None], None]:
    """How to send a message of ``type_name`` on ``writer``: validated and handed over as
    it is when the writer's readers share our process, validated and serialized otherwise."""
    if isinstance(writer, MessageWriter):
        write_message = writer.write_message

        def hand_over(msg: Any, request_id: RequestId | None = None) -> None:
            interfaces.validate(msg, type_name)
            write_message(msg, request_id)

        return hand_over

    def serialize(msg: Any, request_id: RequestId | None = None) -> None:
        writer.write(interfaces.serialize(msg, type_name), request_id)

    return serialize


def sample_bytes(data: Sample, type_name: str, *, check: bool = True
                 ) -> bytes | bytearray | memoryview:
    """The CDR bytes of a received sample: bytes as they are, a message handed over
    in-process serialized (what a raw reader, a recorder or a bridge needs). ``check``
    False skips validating it again: for a reader called as the message is written, right
    after its publisher validated it (a recorder's tap)."""
    if isinstance(data, bytes | bytearray | memoryview):
        return data
    return interfaces.serialize(data, type_name, check=check)


def sample_message(data: Sample, type_name: str) -> Any:
    """The message of a received sample: bytes are deserialized (MessageError when
    malformed), a message handed over in-process is used as it is."""
    if isinstance(data, bytes | bytearray | memoryview):
        return interfaces.deserialize(data, type_name)
    return data


class Inbox:
    """A reader's queue: KEEP_LAST drops the oldest; each sample is handled in turn on
    the event loop, never inside the writer's call."""

    def __init__(
        self,
        node: EntityNode,
        qos: QoSProfile,
        label: Label,
        handler: Callable[[Sample, RequestId | None], None],
    ) -> None:
        maxlen = qos.depth if qos.history is HistoryPolicy.KEEP_LAST else None
        self._queue: deque[tuple[Sample, RequestId | None]] = deque(maxlen=maxlen)
        self._loop = node.context.loop
        self._label = label
        self._handler = handler
        self.dropped = 0
        self.closed = False

    def on_sample(self, data: Sample, request_id: RequestId | None) -> None:
        if self._queue.maxlen is not None and len(self._queue) == self._queue.maxlen:
            self.dropped += 1
        self._queue.append((data, request_id))
        self._loop.call_soon(self._take, self._label)

    def _take(self) -> None:
        if self._queue and not self.closed:
            data, request_id = self._queue.popleft()
            self._handler(data, request_id)

