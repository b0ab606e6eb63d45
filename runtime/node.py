"""Node API in rclpy's shape: publishers, subscriptions, services, timers, parameters.

Nodes talk only through their context's transport. A message published here is validated;
over a transport that crosses processes it is serialized and each subscriber gets its own
deserialized copy; in one process (a :class:`~runtime.transport.MessageWriter`) the
subscribers share the published object, which nobody may change after publishing or
receiving it. Every message stays CDR-serialisable, so any node can move to another
process unchanged.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
from collections import deque
from collections.abc import Callable, Coroutine, Mapping, Sequence
from enum import Enum
from typing import Any, Generic, TypeVar

import interfaces
from interfaces.qos import HistoryPolicy, QoSProfile, as_qos, qos_profile_services_default
from runtime.clock import Clock, Time, seconds_to_ns
from runtime.errors import ClockError, ParameterError, TopicTypeError
from runtime.executor import Context
from runtime.future import Future, Task
from runtime.loop import Handle, Label
from runtime.names import resolve_name, validate_namespace, validate_node_name
from runtime.parameters import (
    Parameter,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
    check_value,
    coerce_value,
    is_missing,
    load_node_yaml,
    parameter_fields,
    type_of_value,
)
from runtime.transport import Endpoint, EndpointKind, MessageWriter, RequestId, Sample, Writer

T = TypeVar("T")
P = TypeVar("P")

def _type_name(msg_type: type | str) -> str:
    if isinstance(msg_type, str):  # UnknownTypeError for a bad name
        return interfaces.type_name(interfaces.get_message(msg_type))
    return interfaces.type_name(msg_type)


def _sender(writer: Writer, type_name: str) -> Callable[[Any, RequestId | None], None]:
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


def _message(data: Sample, type_name: str) -> Any:
    """The message of a received sample: bytes are deserialized (MessageError when
    malformed), a message handed over in-process is used as it is."""
    if isinstance(data, bytes | bytearray | memoryview):
        return interfaces.deserialize(data, type_name)
    return data


def stable_guid(*parts: str) -> int:
    """A 64-bit identifier derived from names, the same in every run (for determinism)."""
    digest = hashlib.blake2b("/".join(parts).encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little")


class NodeLogger:
    """rclpy-style logger: ``node.get_logger().info(...)``, stamped with the node's time."""

    def __init__(self, name: str, clock: Clock) -> None:
        self._logger = logging.getLogger(f"quadmission.{name}")
        self._name = name
        self._clock = clock

    def _log(self, level: int, msg: str, *args: Any) -> None:
        if self._logger.isEnabledFor(level):
            t = self._clock.now().seconds
            self._logger.log(level, f"[{t:.3f}] [{self._name}] {msg}", *args)

    def debug(self, msg: str, *args: Any) -> None:
        self._log(logging.DEBUG, msg, *args)

    def info(self, msg: str, *args: Any) -> None:
        self._log(logging.INFO, msg, *args)

    def warning(self, msg: str, *args: Any) -> None:
        self._log(logging.WARNING, msg, *args)

    warn = warning

    def error(self, msg: str, *args: Any) -> None:
        self._log(logging.ERROR, msg, *args)

    def fatal(self, msg: str, *args: Any) -> None:
        self._log(logging.CRITICAL, msg, *args)


class _Inbox:
    """A reader's queue: KEEP_LAST drops the oldest; each sample is handled in turn on
    the event loop, never inside the writer's call."""

    def __init__(
        self,
        node: Node,
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


class Publisher(Generic[T]):
    """Publishes one message type on one topic."""

    def __init__(self, node: Node, msg_type: type | str, topic: str, qos: QoSProfile) -> None:
        self.msg_type = msg_type
        self.type_name = _type_name(msg_type)
        self.topic_name = node.resolve_name(topic)
        self.qos_profile = qos
        self._node = node
        self._writer = node.context.transport.create_writer(
            Endpoint(self.topic_name, self.type_name, qos, node=node.get_fully_qualified_name()))
        self._send = _sender(self._writer, self.type_name)

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


class Subscription(Generic[T]):
    """Calls ``callback(msg)`` for each message, in arrival order, on the executor."""

    def __init__(
        self,
        node: Node,
        msg_type: type | str,
        topic: str,
        callback: Callable[[Any], None],
        qos: QoSProfile,
        raw: bool = False,
    ) -> None:
        self.msg_type = msg_type
        self.type_name = _type_name(msg_type)
        self.topic_name = node.resolve_name(topic)
        self.qos_profile = qos
        self.callback = callback
        self.raw = raw
        self.malformed = 0
        self._node = node
        self._inbox = _Inbox(node, qos, (node.get_name(), "subscription", self.topic_name),
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
            msg = _message(data, self.type_name)
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


class Timer:
    """Calls ``callback()`` every ``period`` of the node's clock, first one period after
    creation (as rclpy does). Fire times are start + k * period exactly: no drift."""

    def __init__(self, node: Node, period_sec: float, callback: Callable[[], None]) -> None:
        period_ns = seconds_to_ns(period_sec)
        if period_ns <= 0:
            raise ClockError(f"timer period must be positive, got {period_sec} s")
        self.timer_period_ns = period_ns
        self.callback = callback
        self._loop = node.context.loop
        self._label: Label = (node.get_name(), "timer", getattr(callback, "__qualname__", "timer"))
        self._handle: Handle | None = None
        self._canceled = False
        self.reset()

    def reset(self) -> None:
        """Restart the period from now (and un-cancel)."""
        if self._handle is not None:
            self._handle.cancel()
        self._canceled = False
        self._start_ns = self._loop.clock.now().nanoseconds
        self._count = 0
        self._schedule()

    def _schedule(self) -> None:
        self._next_ns = self._start_ns + (self._count + 1) * self.timer_period_ns
        self._handle = self._loop.call_at(self._next_ns, self._fire, self._label)

    def _fire(self) -> None:
        self._count += 1
        self._schedule()
        self.callback()

    def cancel(self) -> None:
        self._canceled = True
        if self._handle is not None:
            self._handle.cancel()

    def is_canceled(self) -> bool:
        return self._canceled

    def time_until_next_call(self) -> int | None:
        """Nanoseconds until the next call, None when canceled."""
        if self._canceled:
            return None
        return self._next_ns - self._loop.clock.now().nanoseconds

    def destroy(self) -> None:
        self.cancel()


class Service:
    """Answers requests: ``callback(request, response) -> response``.

    The callback may instead return a Future of the response, to answer later (the
    action server's get_result does this while a goal is still running).
    """

    def __init__(
        self,
        node: Node,
        srv_type: interfaces.ServiceType,
        name: str,
        callback: Callable[[Any, Any], Any],
        qos: QoSProfile,
    ) -> None:
        self.srv_type = srv_type
        self.service_name = node.resolve_name(name)
        self.callback = callback
        self._node = node
        self._req_name = interfaces.type_name(srv_type.Request)
        self._rep_name = interfaces.type_name(srv_type.Response)
        transport = node.context.transport
        self._writer = transport.create_writer(
            Endpoint(self.service_name, self._rep_name, qos, EndpointKind.REPLY,
                     node.get_fully_qualified_name())
        )
        self._send = _sender(self._writer, self._rep_name)
        self._inbox = _Inbox(node, qos, (node.get_name(), "service", self.service_name),
                             self._handle)
        self._reader = transport.create_reader(
            Endpoint(self.service_name, self._req_name, qos, EndpointKind.REQUEST,
                     node.get_fully_qualified_name()),
            self._inbox.on_sample,
        )

    def _handle(self, data: Sample, request_id: RequestId | None) -> None:
        if request_id is None:
            return
        try:
            request = _message(data, self._req_name)
        except interfaces.MessageError as exc:
            self._node.get_logger().error(f"malformed request on {self.service_name}: {exc}")
            return
        response = self.callback(request, interfaces.new(self.srv_type.Response))
        if isinstance(response, Future):  # answered later, when the future completes
            response.add_done_callback(lambda f: self._reply_later(f, request_id))
        else:
            self._reply(response, request_id)

    def _reply_later(self, future: Future[Any], request_id: RequestId) -> None:
        if future.cancelled() or future.exception() is not None:
            self._node.get_logger().error(
                f"service {self.service_name}: no answer, the handler failed: "
                f"{'cancelled' if future.cancelled() else repr(future.exception())}")
            return
        self._reply(future.result(), request_id)

    def _reply(self, response: Any, request_id: RequestId) -> None:
        if getattr(response, "__msgtype__", None) != self._rep_name:
            raise TopicTypeError(
                f"service {self.service_name}: callback returned {response!r}, "
                f"expected a {self._rep_name}"
            )
        self._send(response, request_id)

    def destroy(self) -> None:
        self._inbox.closed = True
        self._reader.close()
        self._writer.close()


class Client:
    """Calls a service: ``future = client.call_async(request)``."""

    def __init__(
        self, node: Node, srv_type: interfaces.ServiceType, name: str, qos: QoSProfile
    ) -> None:
        self.srv_type = srv_type
        self.service_name = node.resolve_name(name)
        self._node = node
        self._req_name = interfaces.type_name(srv_type.Request)
        self._rep_name = interfaces.type_name(srv_type.Response)
        self._guid = node.next_guid("client", self.service_name)
        self._sequence = 0
        self._pending: dict[int, Future[Any]] = {}
        transport = node.context.transport
        self._writer = transport.create_writer(
            Endpoint(self.service_name, self._req_name, qos, EndpointKind.REQUEST,
                     node.get_fully_qualified_name())
        )
        self._send = _sender(self._writer, self._req_name)
        self._inbox = _Inbox(node, qos, (node.get_name(), "client", self.service_name),
                             self._handle)
        self._reader = transport.create_reader(
            Endpoint(self.service_name, self._rep_name, qos, EndpointKind.REPLY,
                     node.get_fully_qualified_name()),
            self._on_reply,
        )

    def _on_reply(self, data: Sample, request_id: RequestId | None) -> None:
        if request_id is not None and request_id.client_guid == self._guid:
            self._inbox.on_sample(data, request_id)

    def _handle(self, data: Sample, request_id: RequestId | None) -> None:
        assert request_id is not None
        future = self._pending.pop(request_id.sequence, None)
        if future is None or future.done():
            return
        try:
            future.set_result(_message(data, self._rep_name))
        except interfaces.MessageError as exc:
            future.set_exception(exc)

    def call_async(self, request: Any) -> Future[Any]:
        """Send ``request``; the future completes with the response."""
        actual = getattr(request, "__msgtype__", type(request).__name__)
        if actual != self._req_name:
            raise TopicTypeError(
                f"call to {self.service_name}: expected {self._req_name}, got {actual}"
            )
        self._sequence += 1
        future: Future[Any] = Future(self._node.context.loop)
        self._pending[self._sequence] = future
        try:
            self._send(request, RequestId(self._guid, self._sequence))
        except interfaces.MessageError:
            del self._pending[self._sequence]
            self._sequence -= 1
            raise
        return future

    def service_is_ready(self) -> bool:
        return self._writer.matched_count() > 0

    def wait_for_service(self, timeout_sec: float | None = None) -> bool:
        """Whether a server is there. In simulated time nothing appears while we wait,
        so this answers at once; over DDS the transport's discovery decides."""
        return self.service_is_ready()

    def remove_pending_request(self, future: Future[Any]) -> None:
        for seq, pending in list(self._pending.items()):
            if pending is future:
                del self._pending[seq]

    def destroy(self) -> None:
        self._inbox.closed = True
        self._reader.close()
        self._writer.close()


class Node:
    """A ROS 2-style node. Subclass it, declare parameters and entities in ``__init__``.

    ``context`` comes from the executor (``DeterministicExecutor().context``).
    ``parameter_overrides`` win over the node's YAML; ``remappings`` map names as written
    or resolved to new ones, and ``{"__node": "other"}`` renames the node.
    """

    def __init__(
        self,
        node_name: str,
        *,
        context: Context,
        namespace: str = "",
        parameter_overrides: Mapping[str, Any] | None = None,
        remappings: Mapping[str, str] | None = None,
    ) -> None:
        remappings = dict(remappings or {})
        self._name = validate_node_name(remappings.pop("__node", node_name))
        self._namespace = validate_namespace(remappings.pop("__ns", namespace))
        self._remappings = remappings
        self.context = context
        self._guid_counter = 0
        self._entities: list[Any] = []
        self._tasks: list[Task[Any]] = []
        self._sleeps: set[Handle] = set()  # pending sleeps, cancelled on destroy_node
        self._logger = NodeLogger(self.get_fully_qualified_name().lstrip("/"), context.loop.clock)
        self._parameters: dict[str, Parameter] = {}
        self._descriptors: dict[str, ParameterDescriptor] = {}
        self._on_set_callbacks: list[Callable[[list[Parameter]], SetParametersResult]] = []
        self._config_path = (
            context.config_dir / f"{self._name}.yaml" if context.config_dir is not None else None
        )
        self._yaml_params = (
            load_node_yaml(self._config_path, self._name) if self._config_path else {}
        )
        self._overrides = dict(parameter_overrides or {})
        context.nodes.append(self)

    # identity ----------------------------------------------------------------------------
    def get_name(self) -> str:
        return self._name

    def get_namespace(self) -> str:
        return self._namespace

    def get_fully_qualified_name(self) -> str:
        return f"{self._namespace.rstrip('/')}/{self._name}"

    def get_logger(self) -> NodeLogger:
        return self._logger

    def get_clock(self) -> Clock:
        return self.context.loop.clock

    def now(self) -> Time:
        return self.context.loop.clock.now()

    def resolve_name(self, name: str) -> str:
        return resolve_name(name, self._namespace, self._name, self._remappings)

    def next_guid(self, kind: str, name: str) -> int:
        self._guid_counter += 1
        return stable_guid(self.get_fully_qualified_name(), kind, name, str(self._guid_counter))

    # entities ----------------------------------------------------------------------------
    def _keep(self, entity: T) -> T:
        self._entities.append(entity)
        return entity

    def create_publisher(
        self, msg_type: type | str, topic: str, qos_profile: QoSProfile | int
    ) -> Publisher[Any]:
        return self._keep(Publisher(self, msg_type, topic, as_qos(qos_profile)))

    def create_subscription(
        self,
        msg_type: type | str,
        topic: str,
        callback: Callable[[Any], None],
        qos_profile: QoSProfile | int,
        *,
        raw: bool = False,
    ) -> Subscription[Any]:
        """``raw=True`` hands the callback the CDR bytes instead of a message (rclpy's)."""
        return self._keep(
            Subscription(self, msg_type, topic, callback, as_qos(qos_profile), raw=raw)
        )

    def destroy_subscription(self, subscription: Subscription[Any]) -> bool:
        """Stop ``subscription`` (rclpy's): no further callbacks, its reader leaves the
        topic. False when it is not one of this node's live subscriptions."""
        if subscription not in self._entities:
            return False
        self._entities.remove(subscription)
        subscription.destroy()
        return True

    def create_timer(self, timer_period_sec: float, callback: Callable[[], None]) -> Timer:
        return self._keep(Timer(self, timer_period_sec, callback))

    def create_service(
        self,
        srv_type: interfaces.ServiceType | str,
        srv_name: str,
        callback: Callable[[Any, Any], Any],
        qos_profile: QoSProfile = qos_profile_services_default,
    ) -> Service:
        stype = interfaces.get_service(srv_type) if isinstance(srv_type, str) else srv_type
        return self._keep(Service(self, stype, srv_name, callback, qos_profile))

    def create_client(
        self,
        srv_type: interfaces.ServiceType | str,
        srv_name: str,
        qos_profile: QoSProfile = qos_profile_services_default,
    ) -> Client:
        stype = interfaces.get_service(srv_type) if isinstance(srv_type, str) else srv_type
        return self._keep(Client(self, stype, srv_name, qos_profile))

    def create_task(self, coro: Coroutine[Any, Any, T]) -> Task[T]:
        """Run a coroutine on the executor; it may ``await`` futures and ``self.sleep``."""
        task = self.context.create_task(
            coro, (self._name, "task", getattr(coro, "__qualname__", "task"))
        )
        self._tasks = [t for t in self._tasks if not t.done()]
        self._tasks.append(task)
        return task

    def sleep(self, seconds: float) -> Future[None]:
        """A future done after ``seconds`` of the node's clock (``await node.sleep(0.1)``)."""
        loop = self.context.loop
        future: Future[None] = Future(loop)
        t_ns = loop.clock.now().nanoseconds + max(0, seconds_to_ns(seconds))
        sleeps = self._sleeps

        def wake() -> None:
            sleeps.discard(handle)
            if not future.done():
                future.set_result(None)

        handle = loop.call_at(t_ns, wake, (self._name, "sleep", ""))
        sleeps.add(handle)
        return future

    def offload(self, work: Callable[[], T], duration_s: float) -> Future[T]:
        """``work()`` done off the callbacks' thread, its result ready ``duration_s`` of the
        node's clock later: the time that work takes on the vehicle's computer
        (``result = await node.offload(...)``). Under the deterministic executor the work
        runs on its worker thread while the simulation goes on (OpenCV and numpy release
        the GIL, so it overlaps on a second core) and the result is taken at exactly that
        time, waiting for the thread if it is late: the same run as with the work in line.
        Another executor runs it in line, now. ``work`` must not share mutable state with
        the node's callbacks; an exception it raises is the future's."""
        loop = self.context.loop
        future: Future[T] = Future(loop)
        t_ns = loop.clock.now().nanoseconds + max(0, seconds_to_ns(duration_s))
        start = getattr(loop, "start_work", None)
        if start is not None:
            outcome = start(work).result
        else:
            try:
                value = work()
                outcome = lambda: value  # noqa: E731
            except Exception as exc:
                error = exc

                def outcome() -> T:
                    raise error
        sleeps = self._sleeps

        def finish() -> None:
            sleeps.discard(handle)
            try:
                result = outcome()
            except Exception as exc:
                if not future.done():
                    future.set_exception(exc)
                return
            if not future.done():
                future.set_result(result)

        handle = loop.call_at(t_ns, finish,
                              (self._name, "work", getattr(work, "__qualname__", "work")))
        sleeps.add(handle)
        return future

    def destroy_node(self) -> None:
        """Stop everything the node does: its entities, its tasks and pending sleeps."""
        for task in self._tasks:
            task.cancel()
        for handle in self._sleeps:
            handle.cancel()
        self._sleeps.clear()
        for entity in reversed(self._entities):
            entity.destroy()
        self._entities.clear()
        if self in self.context.nodes:
            self.context.nodes.remove(self)

    # parameters --------------------------------------------------------------------------
    def _where(self, name: str) -> str:
        return f"{self._name}.{name}"

    def declare_parameter(
        self,
        name: str,
        value: Any = None,
        descriptor: ParameterDescriptor | None = None,
    ) -> Parameter:
        """Declare a parameter; its value is the launch override, else the node's YAML,
        else ``value``. Type comes from the descriptor or the default."""
        if name in self._parameters:
            raise ParameterError("declared twice", key=self._where(name))
        descriptor = descriptor or ParameterDescriptor()
        source: str | None
        if name in self._overrides:
            raw, source = self._overrides[name], "launch override"
        elif name in self._yaml_params:
            raw, source = self._yaml_params[name], str(self._config_path)
        else:
            raw, source = value, None
        kind = descriptor.type or type_of_value(value) or type_of_value(raw)
        if raw is None or kind is None:
            where = self._config_path or "config/"
            raise ParameterError(
                f"no value (set it in {where} or pass a default); expected "
                f"{dataclasses.replace(descriptor, type=kind).allowed()}",
                key=self._where(name),
            )
        try:
            coerced = coerce_value(self._where(name), kind, raw, descriptor)
            check_value(self._where(name), descriptor, coerced)
        except ParameterError as exc:
            raise exc.with_source(source) from None
        param = Parameter(name, kind, coerced)
        self._parameters[name] = param
        self._descriptors[name] = descriptor
        return param

    def declare_parameters(
        self, namespace: str, parameters: Sequence[tuple[str, Any]]
    ) -> list[Parameter]:
        prefix = f"{namespace}." if namespace else ""
        return [self.declare_parameter(f"{prefix}{n}", v) for n, v in parameters]

    def declare_params(self, cls: type[P], prefix: str = "") -> P:
        """Declare every field of the frozen parameter dataclass ``cls`` (see
        :mod:`runtime.parameters`) and return a validated instance. A nested section's
        fields are declared as ``section.field``; an Enum as a string among its values.
        Fields without a default must be set in the node's YAML."""
        values: dict[str, Any] = {}
        for f in parameter_fields(cls):
            name = f"{prefix}{f.name}"
            if f.section is not None:
                values[f.name] = self.declare_params(f.section, f"{name}.")
                continue
            descriptor, default = f.descriptor, f.default
            if f.enum is not None:
                descriptor = dataclasses.replace(
                    descriptor, type=ParameterType.STRING,
                    choices=tuple(m.value for m in f.enum))
                default = default.value if isinstance(default, Enum) else default
            elif f.kind is None:
                raise ParameterError(
                    f"type of {cls.__name__}.{f.name} cannot be a parameter (use bool, int, "
                    "float, str, tuple[X, ...], an Enum or a nested parameter dataclass)",
                    key=self._where(name))
            declared = self.declare_parameter(
                name, None if is_missing(default) else default, descriptor).value
            values[f.name] = f.convert(self._where(name), declared)
        try:
            return cls(**values)
        except ParameterError as exc:  # a check across fields in __post_init__
            raise exc.prefixed(self._where(prefix.rstrip("."))
                               if prefix else self._name) from None

    def has_parameter(self, name: str) -> bool:
        return name in self._parameters

    def get_parameter(self, name: str) -> Parameter:
        try:
            return self._parameters[name]
        except KeyError:
            raise ParameterError(
                f"not declared; declared: {sorted(self._parameters)}", key=self._where(name)
            ) from None

    def get_parameters_by_prefix(self, prefix: str) -> dict[str, Parameter]:
        dotted = f"{prefix}." if prefix else ""
        return {
            n[len(dotted):]: p for n, p in self._parameters.items() if n.startswith(dotted)
        }

    def add_on_set_parameters_callback(
        self, callback: Callable[[list[Parameter]], SetParametersResult]
    ) -> None:
        self._on_set_callbacks.append(callback)

    def set_parameters(self, parameters: Sequence[Parameter]) -> list[SetParametersResult]:
        """Change declared parameters at run time, each validated like a declaration."""
        results = []
        for p in parameters:
            try:
                if p.name not in self._parameters:
                    raise ParameterError("not declared", key=self._where(p.name))
                old = self._parameters[p.name]
                descriptor = self._descriptors[p.name]
                if descriptor.read_only:
                    raise ParameterError("read-only", key=self._where(p.name))
                value = coerce_value(self._where(p.name), old.type, p.value, descriptor)
                check_value(self._where(p.name), descriptor, value)
            except ParameterError as exc:
                results.append(SetParametersResult(False, str(exc)))
                continue
            new = Parameter(p.name, old.type, value)
            verdict = SetParametersResult(True)
            for cb in self._on_set_callbacks:
                verdict = cb([new])
                if not verdict.successful:
                    break
            if verdict.successful:
                self._parameters[p.name] = new
            results.append(verdict)
        return results

    def check_parameters_declared(self) -> None:
        """Raise ParameterError for a YAML or override key the node never declared."""
        for source, keys in (
            (str(self._config_path), self._yaml_params),
            ("launch overrides", self._overrides),
        ):
            unknown = sorted(k for k in keys if k not in self._parameters)
            if unknown:
                declared = ", ".join(sorted(self._parameters)) or "none"
                raise ParameterError(
                    f"unknown parameter {unknown[0]!r} for node {self._name} "
                    f"(declared: {declared})",
                    key=self._where(unknown[0]),
                    source=source,
                )


__all__ = [
    "Client",
    "Node",
    "NodeLogger",
    "ParameterType",
    "Publisher",
    "Service",
    "Subscription",
    "Timer",
    "sample_bytes",
    "stable_guid",
]
