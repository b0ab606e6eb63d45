"""The Cyclone DDS transport: the transport Protocol over the ``cyclonedds`` wheel.

Node code does not change: a node writes CDR bytes, and those bytes go on the wire as they
are (the DDS transport never skips serialisation). On the wire it speaks ROS 2's
conventions, so a ROS 2 Jazzy machine on the same domain sees our endpoints:

- topics ``rt/<name>``; services ``rq/<name>Request`` and ``rr/<name>Reply``, each sample
  prefixed, after the encapsulation header, by the request id as rmw_cyclonedds frames it
  (the client's 64-bit GUID, then the int64 sequence number); actions are the runtime's
  composition of services and topics (``<name>/_action/send_goal``... ``feedback``,
  ``status``), so they follow;
- types ``pkg::msg::dds_::Type_`` built from the typestore (:mod:`runtime.dds.types`),
  ``@final``, XCDR1; each endpoint's USER_DATA carries ``typehash=RIHS01_...;``;
- QoS mapped one to one (:mod:`runtime.dds.qos`); an incompatible pair is recorded in
  :attr:`DdsTransport.incompatibilities` and logged, naming the topic and the policy.

Delivery is single-threaded: the executor calls :meth:`DdsTransport.wait` and then
:meth:`DdsTransport.dispatch`, which takes every available sample and hands it to the
reader's callback in the executor's thread.
"""

from __future__ import annotations

import logging
import struct
import threading
from collections.abc import Callable
from typing import Any

from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.core import (
    GuardCondition,
    InstanceState,
    Listener,
    ReadCondition,
    SampleState,
    ViewState,
    WaitSet,
)
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from runtime.dds.config import DdsConfig
from runtime.dds.qos import POLICY_NAMES, dds_qos
from runtime.dds.types import dds_topic_name, idl_struct, type_hash
from runtime.errors import RuntimeApiError, TopicTypeError
from runtime.transport import (
    Endpoint,
    EndpointKind,
    Incompatibility,
    Reader,
    RequestId,
    SampleCallback,
    Writer,
)

__all__ = ["DdsTransport"]

_log = logging.getLogger("quadmission.transport.dds")

ENCAPSULATION_BYTES = 4  # CDR_LE header in front of every payload
_REQUEST_HEADER = struct.Struct("<Qq")  # rmw_cyclonedds: uint64 client guid, int64 seq
_ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any
_TAKE_BATCH = 64


def frame_request(data: bytes, request_id: RequestId) -> bytes:
    """A service payload as rmw_cyclonedds writes it: header, request id, message body."""
    return (data[:ENCAPSULATION_BYTES]
            + _REQUEST_HEADER.pack(request_id.client_guid, request_id.sequence)
            + data[ENCAPSULATION_BYTES:])


def unframe_request(data: bytes) -> tuple[bytes, RequestId]:
    """The inverse of :func:`frame_request`."""
    guid, seq = _REQUEST_HEADER.unpack_from(data, ENCAPSULATION_BYTES)
    body = data[:ENCAPSULATION_BYTES] + data[ENCAPSULATION_BYTES + _REQUEST_HEADER.size:]
    return body, RequestId(guid, seq)


class _DdsWriter:
    def __init__(self, transport: DdsTransport, endpoint: Endpoint, writer: DataWriter) -> None:
        self._transport = transport
        self.endpoint = endpoint
        self._writer = writer
        self._ref = writer._ref
        self._service = endpoint.kind is not EndpointKind.TOPIC
        self.closed = False
        self.listener: Listener | None = None

    def write(self, data: bytes, request_id: RequestId | None = None) -> None:
        if self.closed:
            raise RuntimeApiError(f"write on {self.endpoint.name}: the writer was destroyed")
        if self._service:
            if request_id is None:
                raise RuntimeApiError(f"{self.endpoint.name}: a service sample needs a request id")
            data = frame_request(data, request_id)
        ret = ddspy_write(self._ref, data)
        if ret < 0:
            raise RuntimeApiError(f"DDS write on {self.endpoint.name} failed (code {ret})")

    def matched_count(self) -> int:
        return 0 if self.closed else len(self._writer.get_matched_subscriptions())

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._transport._forget(self._writer)


class _DdsReader:
    def __init__(self, transport: DdsTransport, endpoint: Endpoint, reader: DataReader,
                 on_sample: SampleCallback) -> None:
        self._transport = transport
        self.endpoint = endpoint
        self.reader = reader
        self.condition = ReadCondition(reader, _ANY_STATE)
        self.on_sample = on_sample
        self._service = endpoint.kind is not EndpointKind.TOPIC
        self.closed = False
        self.listener: Listener | None = None

    def take(self) -> int:
        """Hand every available sample to the callback; how many there were."""
        n = 0
        while not self.closed:
            ret = ddspy_take(self.reader._ref, _ANY_STATE, _TAKE_BATCH)
            if isinstance(ret, int):
                raise RuntimeApiError(f"DDS take on {self.endpoint.name} failed (code {ret})")
            for data, info in ret:
                if not info.valid_data:
                    continue
                n += 1
                if self._service:
                    body, request_id = unframe_request(data)
                    self.on_sample(body, request_id)
                else:
                    self.on_sample(data, None)
            if len(ret) < _TAKE_BATCH:
                break
        return n

    def matched_count(self) -> int:
        return 0 if self.closed else len(self.reader.get_matched_publications())

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._transport._forget_reader(self)


#: Cyclone allows one configuration per domain in a process: the domains made so far,
#: with the configuration each was made with (a second transport on a domain shares it).
_DOMAINS: dict[int, tuple[Domain, DdsConfig]] = {}


def _domain(config: DdsConfig) -> Domain:
    made = _DOMAINS.get(config.domain_id)
    if made is None:
        made = (Domain(config.domain_id, config.xml()), config)
        _DOMAINS[config.domain_id] = made
    elif made[1] != config:
        raise RuntimeApiError(f"DDS domain {config.domain_id} already runs in this process "
                              f"with {made[1]}; cannot also use {config}")
    return made[0]


class DdsTransport:
    """One DDS participant per process; writers and readers for ROS-named endpoints."""

    def __init__(self, config: DdsConfig | None = None, *, name: str = "quadmission") -> None:
        self.config = config or DdsConfig()
        self._domain = _domain(self.config)
        self.participant = DomainParticipant(self.config.domain_id)
        self._topics: dict[str, tuple[Topic[Any], str]] = {}
        self._readers: list[_DdsReader] = []
        self._waitset = WaitSet(self.participant)
        self._wake = GuardCondition(self.participant)
        self._waitset.attach(self._wake)
        self._lock = threading.Lock()
        self.incompatibilities: list[Incompatibility] = []
        self.name = name

    # -- endpoints --------------------------------------------------------------------------
    def _topic(self, endpoint: Endpoint) -> Topic[Any]:
        dds_name = dds_topic_name(endpoint.name, endpoint.kind)
        known = self._topics.get(dds_name)
        if known is not None:
            topic, type_name = known
            if type_name != endpoint.type_name:
                raise TopicTypeError(
                    f"{endpoint.kind.value} {endpoint.name!r} carries {type_name}; "
                    f"cannot also use it for {endpoint.type_name}")
            return topic
        service = endpoint.kind is not EndpointKind.TOPIC
        topic = Topic(self.participant, dds_name, idl_struct(endpoint.type_name, service))
        self._topics[dds_name] = (topic, endpoint.type_name)
        return topic

    def _user_data(self, endpoint: Endpoint) -> bytes:
        return f"typehash={type_hash(endpoint.type_name)};".encode()

    def _incompatible(self, endpoint: Endpoint, side: str) -> Callable[[Any, Any], None]:
        def note(_entity: Any, status: Any) -> None:
            policy = POLICY_NAMES.get(int(status.last_policy_id), str(status.last_policy_id))
            reason = f"{side} QoS incompatible with a peer's on policy {policy}"
            with self._lock:
                self.incompatibilities.append(Incompatibility(endpoint.name, reason))
            _log.warning("incompatible QoS on %s: %s; they will not communicate",
                         endpoint.name, reason)
        return note

    def create_writer(self, endpoint: Endpoint) -> Writer:
        topic = self._topic(endpoint)
        listener = Listener(on_offered_incompatible_qos=self._incompatible(endpoint, "offered"))
        writer = DataWriter(self.participant, topic,
                            qos=dds_qos(endpoint.qos, self._user_data(endpoint)),
                            listener=listener)
        wrapped = _DdsWriter(self, endpoint, writer)
        wrapped.listener = listener  # kept alive as long as the writer
        return wrapped

    def create_reader(self, endpoint: Endpoint, on_sample: SampleCallback) -> Reader:
        topic = self._topic(endpoint)
        listener = Listener(
            on_requested_incompatible_qos=self._incompatible(endpoint, "requested"))
        reader = DataReader(self.participant, topic,
                            qos=dds_qos(endpoint.qos, self._user_data(endpoint)),
                            listener=listener)
        wrapped = _DdsReader(self, endpoint, reader, on_sample)
        wrapped.listener = listener  # kept alive as long as the reader
        self._waitset.attach(wrapped.condition)
        self._readers.append(wrapped)
        return wrapped

    def _forget(self, writer: DataWriter) -> None:
        writer.__del__()

    def _forget_reader(self, reader: _DdsReader) -> None:
        self._waitset.detach(reader.condition)
        self._readers.remove(reader)
        reader.condition.__del__()
        reader.reader.__del__()

    # -- delivery ---------------------------------------------------------------------------
    def wait(self, timeout_s: float) -> bool:
        """Block until a sample is available, :meth:`wake` is called, or ``timeout_s``."""
        triggered = self._waitset.wait(duration(seconds=max(0.0, timeout_s)))
        self._wake.set(False)
        return triggered > 0

    def wake(self) -> None:
        """Make a pending :meth:`wait` return (safe from any thread or a signal handler)."""
        self._wake.set(True)

    def dispatch(self) -> int:
        """Take every available sample, in reader creation order; how many there were."""
        return sum(reader.take() for reader in list(self._readers))

    def close(self) -> None:
        """Delete the participant and everything in it."""
        self.participant.__del__()
