"""Transports move serialized messages between endpoints; nodes never share objects.

A transport knows topics, not nodes: a writer writes CDR bytes, every matched reader's
``on_sample`` receives them. A transport whose endpoints share one process may also offer
``write_message`` (:class:`MessageWriter`): the validated message object itself is handed
to the readers, unserialized (zero-copy; receivers treat it as read-only). Readers then get
either CDR bytes or a message, and deserialize only bytes. The ROS 2 transport
(:mod:`runtime.ros2`) always serializes. Services travel as a request topic and a reply
topic, each sample tagged with a RequestId (the client's GUID and a sequence number), as
ROS 2 frames them on the wire. The ROS 2 transport implements the same Protocol on rclpy's
own services, so node code does not change when a node moves to another process.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any, Protocol, runtime_checkable

from interfaces.qos import DurabilityPolicy, HistoryPolicy, QoSProfile
from runtime.errors import RuntimeApiError, TopicTypeError

_log = logging.getLogger("quadmission.transport")


class EndpointKind(Enum):
    """What a name is on the wire: a topic, or one half of a service."""

    TOPIC = "topic"
    REQUEST = "request"
    REPLY = "reply"


@dataclass(frozen=True)
class Endpoint:
    """One writer's or reader's view of a channel."""

    name: str  # fully resolved ROS name, e.g. /fmu/out/vehicle_odometry
    type_name: str  # e.g. px4_msgs/msg/VehicleOdometry
    qos: QoSProfile
    kind: EndpointKind = EndpointKind.TOPIC
    node: str = ""  # fully qualified name of the node that owns it ("" for none)


@dataclass(frozen=True)
class RequestId:
    """Identifies one service request: the client's GUID and its sequence number."""

    client_guid: int
    sequence: int


Sample = Any
"""What a reader receives: CDR ``bytes``, or (from a :class:`MessageWriter`) the message."""

SampleCallback = Callable[[Sample, RequestId | None], None]


class Writer(Protocol):
    def write(self, data: bytes, request_id: RequestId | None = None) -> None: ...

    def matched_count(self) -> int: ...

    def close(self) -> None: ...


@runtime_checkable
class MessageWriter(Protocol):
    """A writer whose readers live in the same process: it may pass the message object."""

    def write_message(self, msg: Any, request_id: RequestId | None = None) -> None: ...


class Reader(Protocol):
    def matched_count(self) -> int: ...

    def close(self) -> None: ...


class Transport(Protocol):
    """Creates writers and readers for endpoints, and lists the graph's topics."""

    def create_writer(self, endpoint: Endpoint) -> Writer: ...

    def create_reader(self, endpoint: Endpoint, on_sample: SampleCallback) -> Reader: ...

    def topic_names_and_types(self) -> list[tuple[str, str]]: ...


@dataclass(frozen=True)
class Incompatibility:
    """A writer and a reader on the same channel whose QoS do not match."""

    name: str
    reason: str


class _Channel:
    def __init__(self, name: str, kind: EndpointKind, type_name: str) -> None:
        self.name = name
        self.kind = kind
        self.type_name = type_name
        self.writers: list[_InProcessWriter] = []
        self.readers: list[_InProcessReader] = []
        self.version = 0  # bumped whenever an endpoint joins or leaves: matches are cached


class _InProcessWriter:
    def __init__(self, channel: _Channel, endpoint: Endpoint) -> None:
        self._channel = channel
        self.endpoint = endpoint
        qos = endpoint.qos
        self.history: deque[tuple[Sample, RequestId | None]] | None = None
        if qos.durability is DurabilityPolicy.TRANSIENT_LOCAL:
            maxlen = qos.depth if qos.history is HistoryPolicy.KEEP_LAST else None
            self.history = deque(maxlen=maxlen)
        self.samples_written = 0
        self.closed = False
        self._matched_version = -1
        self._matched: tuple[_InProcessReader, ...] = ()

    def _matched_readers(self) -> tuple[_InProcessReader, ...]:
        """The readers whose QoS matches ours (recomputed when an endpoint joins or leaves)."""
        channel = self._channel
        if self._matched_version != channel.version:
            self._matched = tuple(r for r in channel.readers if r.matches(self))
            self._matched_version = channel.version
        return self._matched

    def write(self, data: bytes, request_id: RequestId | None = None) -> None:
        self.write_message(data, request_id)

    def write_message(self, data: Sample, request_id: RequestId | None = None) -> None:
        """Hand ``data`` (CDR bytes or a validated message) to every matched reader."""
        if self.closed:
            raise RuntimeApiError(f"write on {self.endpoint.name}: the writer was destroyed")
        self.samples_written += 1
        if self.history is not None:
            self.history.append((data, request_id))
        matched = (self._matched if self._matched_version == self._channel.version
                   else self._matched_readers())
        for reader in matched:
            reader.on_sample(data, request_id)

    def matched_count(self) -> int:
        return len(self._matched_readers())

    def close(self) -> None:
        self.closed = True
        if self in self._channel.writers:
            self._channel.writers.remove(self)
            self._channel.version += 1


class _InProcessReader:
    def __init__(self, channel: _Channel, endpoint: Endpoint, on_sample: SampleCallback) -> None:
        self._channel = channel
        self.endpoint = endpoint
        self.on_sample = on_sample

    def matches(self, writer: _InProcessWriter) -> bool:
        return self.endpoint.qos.incompatibility(writer.endpoint.qos) is None

    def matched_count(self) -> int:
        return sum(1 for w in self._channel.writers if self.matches(w))

    def close(self) -> None:
        if self in self._channel.readers:
            self._channel.readers.remove(self)
            self._channel.version += 1


class InProcessTransport:
    """All endpoints in one process; delivery is synchronous and in creation order.

    Writers are :class:`MessageWriter`\\ s: publishers hand over message objects, shared by
    every reader and never serialized (a test round-trips every type through CDR apart).

    QoS is honoured as ROS 2 honours it: incompatible pairs do not match (and are recorded
    in ``incompatibilities``), a TRANSIENT_LOCAL writer keeps its last ``depth`` samples and
    hands them to a TRANSIENT_LOCAL reader that joins late, a VOLATILE reader gets only
    what is written after it joined. Readers' KEEP_LAST queues live in the subscription.
    """

    def __init__(self) -> None:
        self._channels: dict[tuple[EndpointKind, str], _Channel] = {}
        self.incompatibilities: list[Incompatibility] = []

    def _channel(self, endpoint: Endpoint) -> _Channel:
        key = (endpoint.kind, endpoint.name)
        channel = self._channels.get(key)
        if channel is None:
            channel = _Channel(endpoint.name, endpoint.kind, endpoint.type_name)
            self._channels[key] = channel
        elif channel.type_name != endpoint.type_name:
            raise TopicTypeError(
                f"{endpoint.kind.value} {endpoint.name!r} carries {channel.type_name}; "
                f"cannot also use it for {endpoint.type_name}"
            )
        return channel

    def _note_incompatible(self, reader: Endpoint, writer: Endpoint) -> None:
        reason = reader.qos.incompatibility(writer.qos)
        if reason is not None:
            self.incompatibilities.append(Incompatibility(reader.name, reason))
            _log.warning("incompatible QoS on %s: %s; they will not communicate",
                         reader.name, reason)

    def create_writer(self, endpoint: Endpoint) -> Writer:
        channel = self._channel(endpoint)
        writer = _InProcessWriter(channel, endpoint)
        channel.writers.append(writer)
        channel.version += 1
        for reader in channel.readers:
            self._note_incompatible(reader.endpoint, endpoint)
        return writer

    def create_reader(self, endpoint: Endpoint, on_sample: SampleCallback) -> Reader:
        channel = self._channel(endpoint)
        reader = _InProcessReader(channel, endpoint, on_sample)
        channel.readers.append(reader)
        channel.version += 1
        for writer in channel.writers:
            self._note_incompatible(endpoint, writer.endpoint)
            if (
                writer.history
                and endpoint.qos.durability is DurabilityPolicy.TRANSIENT_LOCAL
                and reader.matches(writer)
            ):
                for data, request_id in writer.history:
                    on_sample(data, request_id)
        return reader

    def samples_written(self) -> dict[tuple[str, str], int]:
        """Samples written so far per (name, type), services' halves included (benchmarks)."""
        counts: dict[tuple[str, str], int] = {}
        for channel in self._channels.values():
            key = (channel.name, channel.type_name)
            counts[key] = counts.get(key, 0) + sum(w.samples_written for w in channel.writers)
        return counts

    def writer_endpoints(self) -> list[Endpoint]:
        """Every open writer's endpoint, services' halves included (as ``ros2 topic info
        -v`` lists publishers: name, type, QoS, node)."""
        return [w.endpoint for c in self._channels.values() for w in c.writers]

    def reader_endpoints(self) -> list[Endpoint]:
        """Every open reader's endpoint, services' halves included."""
        return [r.endpoint for c in self._channels.values() for r in c.readers]

    def topic_names_and_types(self) -> list[tuple[str, str]]:
        """Like ``ros2 topic list -t``: every topic with its type, sorted."""
        return sorted(
            (c.name, c.type_name) for c in self._channels.values() if c.kind is EndpointKind.TOPIC
        )
