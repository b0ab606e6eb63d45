"""The ROS 2 transport: the transport Protocol over rclpy (Fast DDS), each node a real rcl node.

Every node of ours gets an rcl node of the same name and namespace in this process's
rclpy context (:attr:`Endpoint.node`; endpoints without a node, such as the executor's
``/clock`` reader, belong to one node named after the process). Its entities are rclpy's,
with the declared QoS:

- a topic writer is an rclpy publisher that publishes our CDR bytes as they are
  (``publish_raw``), a topic reader an rclpy subscription with ``raw=True``: messages
  cross as the CDR rosbags writes and reads, never converted;
- a service is an rclpy service, a client an rclpy client: rclpy takes and sends its own
  message objects there, so requests and replies are converted at this boundary with
  rclpy's C serializer (our CDR <-> rosidl class); actions are composed of services and
  topics with ROS 2's names and types (:mod:`runtime.action`), so they are ROS 2 actions
  on the wire and in the graph.

Delivery is single-threaded: the executor calls :meth:`wait` (an rcl wait set over every
entity and a guard condition) and then :meth:`dispatch`, which takes what is ready and
hands it to the readers' callbacks in its thread. rclpy's
own executor is not used; the rcl nodes' parameter services are answered here too.
rclpy's signal handlers are not installed: the process decides what SIGINT and SIGTERM do.
"""

from __future__ import annotations

import itertools
import logging
import re
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import rclpy
from rclpy.clock import ClockType
from rclpy.context import Context
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node as RclNode
from rclpy.parameter import Parameter as RclParameter
from rclpy.qos import QoSPolicyKind
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time as RclTime

from runtime.errors import RuntimeApiError, TopicTypeError
from runtime.node import Node
from runtime.ros2.config import Ros2Config
from runtime.ros2.parameters import mirror_parameters
from runtime.ros2.qos import rclpy_qos
from runtime.ros2.types import rclpy_type, service_type_of
from runtime.transport import (
    Endpoint,
    EndpointKind,
    Incompatibility,
    Reader,
    RequestId,
    SampleCallback,
    Writer,
)

__all__ = ["Ros2Transport"]

_log = logging.getLogger("quadmission.transport.ros2")
_NS_PER_S = 1_000_000_000
#: The incompatible-QoS events and the rcl nodes' parameter services (for foreign tools)
#: are in a wait at most this often [s of host time]: an event stays ready, and a request
#: waits, until taken, and a process wakes hundreds of times a second for its data and
#: /clock anyway. In every wait they were half of a node process's wait set (six services
#: per rcl node, an event per publisher and subscription), and rcl's wait costs by size.
_SELDOM_EVERY_S = 0.1


def _noop(*_: Any) -> None:
    """The callback rclpy requires; ours are called from :meth:`Ros2Transport.dispatch`."""


def _split(fqn: str) -> tuple[str, str]:
    namespace, _, name = fqn.rpartition("/")
    return name, namespace or "/"


def _process_node_name(name: str) -> str:
    """The hidden rcl node (leading underscore) of the process itself."""
    return "_process_" + re.sub(r"[^A-Za-z0-9_]", "_", name)


class _TopicWriter:
    def __init__(self, endpoint: Endpoint, publisher: Any) -> None:
        self.endpoint = endpoint
        self._publisher = publisher
        self._publish_raw = publisher.handle.publish_raw
        self.closed = False

    def write(self, data: bytes, request_id: RequestId | None = None) -> None:
        if self.closed:
            raise RuntimeApiError(f"write on {self.endpoint.name}: the writer was destroyed")
        self._publish_raw(data)

    def matched_count(self) -> int:
        return 0 if self.closed else self._publisher.get_subscription_count()

    def close(self) -> None:
        self.closed = True


@dataclass
class _Service:
    """One rclpy service: requests taken with their header, replies sent with it."""

    endpoint_name: str
    service: Any
    srv_type: Any
    on_sample: SampleCallback | None = None
    headers: dict[int, Any] = field(default_factory=dict)


@dataclass
class _Client:
    """One rclpy client: our request ids by rcl sequence number, until the reply."""

    endpoint_name: str
    client: Any
    srv_type: Any
    on_sample: SampleCallback | None = None
    pending: dict[int, RequestId] = field(default_factory=dict)


class _ReplyWriter:
    def __init__(self, endpoint: Endpoint, service: _Service) -> None:
        self.endpoint = endpoint
        self._service = service
        self.closed = False

    def write(self, data: bytes, request_id: RequestId | None = None) -> None:
        if self.closed:
            raise RuntimeApiError(f"write on {self.endpoint.name}: the writer was destroyed")
        if request_id is None:
            raise RuntimeApiError(f"{self.endpoint.name}: a reply needs the request's id")
        header = self._service.headers.pop(request_id.client_guid, None)
        if header is None:
            raise RuntimeApiError(f"{self.endpoint.name}: no request {request_id} to answer")
        response = deserialize_message(bytes(data), self._service.srv_type.Response)
        self._service.service.send_response(response, header)

    def matched_count(self) -> int:
        return 1

    def close(self) -> None:
        self.closed = True


class _RequestWriter:
    def __init__(self, endpoint: Endpoint, client: _Client) -> None:
        self.endpoint = endpoint
        self._client = client
        self.closed = False

    def write(self, data: bytes, request_id: RequestId | None = None) -> None:
        if self.closed:
            raise RuntimeApiError(f"write on {self.endpoint.name}: the writer was destroyed")
        if request_id is None:
            raise RuntimeApiError(f"{self.endpoint.name}: a request needs an id")
        request = deserialize_message(bytes(data), self._client.srv_type.Request)
        sequence = self._client.client.handle.send_request(request)
        self._client.pending[sequence] = request_id

    def matched_count(self) -> int:
        return int(not self.closed and self._client.client.service_is_ready())

    def close(self) -> None:
        self.closed = True


class _Reader:
    def __init__(self, transport: Ros2Transport, endpoint: Endpoint, entity: Any,
                 count: Callable[[], int]) -> None:
        self._transport = transport
        self.endpoint = endpoint
        self.entity = entity
        self._count = count
        self.closed = False

    def matched_count(self) -> int:
        return 0 if self.closed else self._count()

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._transport._forget(self.entity)
            if self.endpoint.kind is EndpointKind.TOPIC:  # a service's halves share it
                self._transport.rcl_node(self.endpoint.node).destroy_subscription(self.entity)


@dataclass
class _WaitPlan:
    """One wait set and how to fill and read it (:meth:`Ros2Transport._build_wait_set`)."""

    wait_set: Any
    adds: list[tuple[Callable[[Any], Any], Any]]  # (the wait set's add_*, a handle)
    seldom: list[tuple[Callable[[Any], Any], Any]]  # the same, every _SELDOM_EVERY_S
    takers: dict[int, Callable[[], None]]  # a ready entity's pointer -> take what it has
    events: list[Any]  # the rcl events of the handlers below
    handlers: list[Any]  # rclpy's incompatible-QoS event handlers
    rank: dict[int, int] = field(init=False)  # pointer -> place in creation order

    def __post_init__(self) -> None:
        self.rank = {pointer: i for i, pointer in enumerate(self.takers)}


class Ros2Transport:
    """One rclpy context per transport; an rcl node per node of ours."""

    def __init__(self, config: Ros2Config | None = None, *, name: str = "quadmission",
                 use_sim_time: bool = False) -> None:
        self.config = config or Ros2Config()
        self.config.apply()
        self.name = name
        self.use_sim_time = use_sim_time
        self.context = Context()
        rclpy.init(context=self.context, domain_id=self.config.domain_id,
                   signal_handler_options=SignalHandlerOptions.NO)
        self._nodes: dict[str, RclNode] = {}
        self._mirrored: weakref.WeakSet[Node] = weakref.WeakSet()  # parameters mirrored
        self._clocks: list[tuple[Any, list[Any]]] | None = None  # (time source, clocks)
        self._seldom: set[Any] = set()  # rclpy's parameter services (_SELDOM_EVERY_S)
        self._process_node = _process_node_name(name)
        self._guard = _rclpy.GuardCondition(self.context.handle)
        # what the wait set holds; entity -> how to take from it
        self._subs: dict[Any, Callable[[], None]] = {}
        self._services: dict[Any, Callable[[], None]] = {}
        self._clients: dict[Any, Callable[[], None]] = {}
        self._unpaired_services: dict[tuple[str, str], list[_Service]] = {}
        self._unpaired_clients: dict[tuple[str, str], list[_Client]] = {}
        self._topic_types: dict[str, str] = {}
        self._request_ids = itertools.count(1)
        self._wait_set: _WaitPlan | None = None  # made again when an entity comes or goes
        # a topic's incompatible-QoS event handlers (rclpy's), by the entity they watch
        self._events: dict[Any, list[Any]] = {}
        #: incompatible QoS pairs met so far, each named by topic, side and policy
        self.incompatibilities: list[Incompatibility] = []
        self._ready: tuple[_WaitPlan, list[int], list[Any]] | None = None  # the last wait's
        self._seldom_due = 0.0  # host monotonic time the seldom entities are next waited on
        self._closed = False
        #: told ``(node name, ns from a message's reception to its take)`` for each message
        #: a reader made from now on takes (:mod:`runtime.processes.callback_stats`)
        self.take_observer: Callable[[str, int], None] | None = None

    # -- nodes -----------------------------------------------------------------------------
    def rcl_node(self, fqn: str = "") -> RclNode:
        """The rcl node of our node ``fqn`` (``/ns/name``), made on first use; ``""`` is
        the process's own (hidden) node."""
        node = self._nodes.get(fqn)
        if node is None:
            name, namespace = _split(fqn) if fqn else (self._process_node, "/")
            overrides = [RclParameter("use_sim_time", RclParameter.Type.BOOL, True)] \
                if self.use_sim_time else []
            node = RclNode(name, namespace=namespace, context=self.context,
                           parameter_overrides=overrides)
            time_source = node._time_source
            if time_source._clock_sub is not None:  # we follow /clock once per process
                node.destroy_subscription(time_source._clock_sub)
                time_source._clock_sub = None
            for srv in node.services:  # parameter services, answered by rclpy's callbacks
                self._services[srv] = self._native_service(srv)
                self._seldom.add(srv)
            self._nodes[fqn] = node
            self._wait_set = self._clocks = None
        return node

    def mirror_parameters(self, node: Node) -> None:
        """Declare ``node``'s parameters on its rcl node, and those it declares later
        (:mod:`runtime.ros2.parameters`); a node already mirrored is left as it is."""
        if node in self._mirrored:
            return
        mirror_parameters(node, self.rcl_node(node.get_fully_qualified_name()))
        self._mirrored.add(node)

    def set_time(self, t_ns: int) -> None:
        """Move every rcl node's ROS clock to simulated time ``t_ns`` (``use_sim_time``)."""
        if not self.use_sim_time:
            return
        now = RclTime(nanoseconds=t_ns, clock_type=ClockType.ROS_TIME)
        if self._clocks is None:  # rclpy's ROSClock.set_ros_time_override, without its
            # checks and lock per call (this thread is the only one to move them)
            self._clocks = [(node._time_source, [c.handle for c in
                                                 node._time_source._associated_clocks])
                            for node in self._nodes.values()]
        handle = now._time_handle
        for time_source, clocks in self._clocks:
            time_source._last_time_set = now  # what a clock attached later starts at
            for clock in clocks:
                clock.set_ros_time_override(handle)

    # -- endpoints -------------------------------------------------------------------------
    def _check_type(self, endpoint: Endpoint) -> None:
        if endpoint.kind is not EndpointKind.TOPIC:
            return
        known = self._topic_types.setdefault(endpoint.name, endpoint.type_name)
        if known != endpoint.type_name:
            raise TopicTypeError(f"topic {endpoint.name!r} carries {known}; cannot also "
                                 f"use it for {endpoint.type_name}")

    def create_writer(self, endpoint: Endpoint) -> Writer:
        self._check_type(endpoint)
        node = self.rcl_node(endpoint.node)
        qos = rclpy_qos(endpoint.qos)
        key = (endpoint.node, endpoint.name)
        if endpoint.kind is EndpointKind.TOPIC:
            noted = self._incompatible(endpoint, "offered")
            pub = node.create_publisher(
                rclpy_type(endpoint.type_name), endpoint.name, qos,
                event_callbacks=PublisherEventCallbacks(incompatible_qos=noted))
            self._watch_events(pub, noted)
            return _TopicWriter(endpoint, pub)
        srv_type = service_type_of(endpoint.type_name)
        if endpoint.kind is EndpointKind.REPLY:  # a service of ours: its reply half
            service = self._service(endpoint, srv_type, qos)
            return _ReplyWriter(endpoint, service)
        client = _Client(endpoint.name, node.create_client(srv_type, endpoint.name,
                                                            qos_profile=qos), srv_type)
        self._unpaired_clients.setdefault(key, []).append(client)
        self._clients[client.client] = lambda: self._take_replies(client)
        self._wait_set = None
        return _RequestWriter(endpoint, client)

    def _service(self, endpoint: Endpoint, srv_type: Any, qos: Any) -> _Service:
        """The service of ``endpoint``: the one its other half made, or a new one."""
        key = (endpoint.node, endpoint.name)
        waiting = self._unpaired_services.setdefault(key, [])
        for service in waiting:
            if (service.on_sample is None) == (endpoint.kind is EndpointKind.REQUEST):
                waiting.remove(service)
                return service
        service = _Service(endpoint.name, self.rcl_node(endpoint.node).create_service(
            srv_type, endpoint.name, _noop, qos_profile=qos), srv_type)
        waiting.append(service)
        self._services[service.service] = lambda: self._take_requests(service)
        self._wait_set = None
        return service

    def create_reader(self, endpoint: Endpoint, on_sample: SampleCallback) -> Reader:
        self._check_type(endpoint)
        node = self.rcl_node(endpoint.node)
        qos = rclpy_qos(endpoint.qos)
        if endpoint.kind is EndpointKind.TOPIC:
            noted = self._incompatible(endpoint, "requested")
            sub = node.create_subscription(
                rclpy_type(endpoint.type_name), endpoint.name, _noop, qos, raw=True,
                event_callbacks=SubscriptionEventCallbacks(incompatible_qos=noted))
            self._watch_events(sub, noted)
            self._subs[sub] = self._taker(sub, on_sample, self.take_observer,
                                          endpoint.node.rsplit("/", 1)[-1])
            self._wait_set = None
            return _Reader(self, endpoint, sub, sub.get_publisher_count)
        if endpoint.kind is EndpointKind.REQUEST:
            service = self._service(endpoint, service_type_of(endpoint.type_name), qos)
            service.on_sample = on_sample
            return _Reader(self, endpoint, service.service, lambda: 1)
        waiting = self._unpaired_clients.get((endpoint.node, endpoint.name))
        if not waiting:
            raise RuntimeApiError(f"reply reader for {endpoint.name} on {endpoint.node!r} "
                                  "without its client's request writer")
        client = waiting.pop(0)
        client.on_sample = on_sample
        return _Reader(self, endpoint, client.client,
                       lambda: int(client.client.service_is_ready()))

    def topic_names_and_types(self) -> list[tuple[str, str]]:
        """The graph's topics, as ``ros2 topic list -t`` gives them (any node of any
        process on the domain), with their type: those our typestore knows, one type each
        (a topic carried with two types, or with a type we cannot decode, is left out)."""
        import interfaces

        known = set(interfaces.typestore().fielddefs)
        return sorted((name, types[0]) for name, types
                      in self.rcl_node().get_topic_names_and_types()
                      if len(types) == 1 and types[0] in known)

    def _forget(self, entity: Any) -> None:
        for table in (self._subs, self._services, self._clients, self._events):
            table.pop(entity, None)
        self._seldom.discard(entity)
        for plan in (self._wait_set, self._ready and self._ready[0]):
            if plan:  # a dispatch to come or under way must not take from it
                plan.takers.pop(entity.handle.pointer, None)
        self._wait_set = None

    # -- QoS events ------------------------------------------------------------------------
    def _incompatible(self, endpoint: Endpoint, side: str) -> Callable[[Any], None]:
        """rcl's incompatible-QoS event of a topic's endpoint: recorded and logged, naming
        the topic and the policy (``offered``: our writer; ``requested``: our reader)."""
        def note(info: Any) -> None:
            policy = QoSPolicyKind(int(info.last_policy_kind)).name
            reason = f"{side} QoS incompatible with a peer's on policy {policy}"
            self.incompatibilities.append(Incompatibility(endpoint.name, reason))
            _log.warning("incompatible QoS on %s: %s; they will not communicate",
                         endpoint.name, reason)
        return note

    def _watch_events(self, entity: Any, callback: Callable[[Any], None]) -> None:
        """Wait on ``entity``'s event handlers that call ``callback`` (rclpy adds others of
        its own, which log; ours record)."""
        self._events[entity] = [h for h in entity.event_handlers if h.callback is callback]
        self._wait_set = None

    # -- taking ----------------------------------------------------------------------------
    @staticmethod
    def _taker(sub: Any, on_sample: SampleCallback,
               observe: Callable[[str, int], None] | None = None,
               node: str = "") -> Callable[[], None]:
        take, msg_type = sub.handle.take_message, sub.msg_type

        def take_all() -> None:
            while True:
                taken = take(msg_type, True)
                if taken is None:
                    return
                on_sample(taken[0], None)

        if observe is None:
            return take_all
        note: Callable[[str, int], None] = observe

        def take_all_observed() -> None:  # rmw's reception stamp is on the system clock
            while True:
                taken = take(msg_type, True)
                if taken is None:
                    return
                received = taken[1]["received_timestamp"]
                if received:  # 0: an rmw that does not stamp
                    note(node, time.time_ns() - received)
                on_sample(taken[0], None)

        return take_all_observed

    def _take_requests(self, service: _Service) -> None:
        handle, request_type = service.service.handle, service.srv_type.Request
        while True:
            request, header = handle.service_take_request(request_type)
            if header is None:
                return
            if service.on_sample is None:
                continue
            key = next(self._request_ids)
            service.headers[key] = header
            request_id = RequestId(key, header.request_id.sequence_number)
            service.on_sample(serialize_message(request), request_id)

    def _take_replies(self, client: _Client) -> None:
        handle, response_type = client.client.handle, client.srv_type.Response
        while True:
            header, response = handle.take_response(response_type)
            if header is None:
                return
            request_id = client.pending.pop(header.request_id.sequence_number, None)
            if request_id is not None and client.on_sample is not None:
                client.on_sample(serialize_message(response), request_id)

    @staticmethod
    def _native_service(srv: Any) -> Callable[[], None]:
        """rclpy's own services (parameters): answered by their callbacks, as rclpy does."""
        def answer() -> None:
            while True:
                request, header = srv.handle.service_take_request(srv.srv_type.Request)
                if header is None:
                    return
                srv.send_response(srv.callback(request, srv.srv_type.Response()), header)
        return answer

    # -- delivery --------------------------------------------------------------------------
    def _build_wait_set(self) -> _WaitPlan:
        """The wait set and what fills it, made again only when an entity comes or goes:
        a wait then adds the entities' handles (rcl empties the set at each wait), looks
        up what is ready by pointer, and asks rcl about its events by index."""
        handlers = [h for handlers in self._events.values() for h in handlers]
        ws = _rclpy.WaitSet(len(self._subs), 1, 0, len(self._clients), len(self._services),
                            len(handlers), self.context.handle)
        adds: list[tuple[Callable[[Any], Any], Any]] = []
        seldom: list[tuple[Callable[[Any], Any], Any]] = []
        takers: dict[int, Callable[[], None]] = {}
        for add, table in ((ws.add_subscription, self._subs), (ws.add_client, self._clients),
                           (ws.add_service, self._services)):
            for entity, take in table.items():
                (seldom if entity in self._seldom else adds).append((add, entity.handle))
                takers[entity.handle.pointer] = take
        adds.append((ws.add_guard_condition, self._guard))
        # rclpy's EventHandler adds its rcl event and remembers the index; we do the same,
        # without its lock per call (one thread waits, takes and destroys here)
        events = [h._EventHandler__event for h in handlers]
        return _WaitPlan(ws, adds, seldom, takers, events, handlers)

    def wait(self, timeout_s: float) -> bool:
        """Block until an entity is ready, :meth:`wake` is called, or ``timeout_s``."""
        if self._closed:
            return False
        plan = self._wait_set
        if plan is None:
            plan = self._wait_set = self._build_wait_set()
        ws = plan.wait_set
        ws.clear_entities()
        for add, handle in plan.adds:
            add(handle)
        indices: list[int] = []
        if time.monotonic() >= self._seldom_due:
            for add, handle in plan.seldom:
                add(handle)
            add_event = ws.add_event
            indices = [add_event(event) for event in plan.events]
            self._seldom_due = time.monotonic() + _SELDOM_EVERY_S
        ws.wait(max(0, round(timeout_s * _NS_PER_S)))
        ready = ws.get_ready_entities("subscription")
        ready += ws.get_ready_entities("client")
        ready += ws.get_ready_entities("service")
        fired: list[Any] = []
        if indices:
            is_ready = ws.is_ready
            fired = [h for i, h in zip(indices, plan.handlers, strict=True)
                     if is_ready("event", i)]
        self._ready = (plan, ready, fired)
        return bool(ready or fired)

    def wake(self) -> None:
        """Make a pending :meth:`wait` return (safe from a signal handler)."""
        if not self._closed:
            self._guard.trigger_guard_condition()

    def dispatch(self) -> int:
        """Take what is ready (as found by the last :meth:`wait`, else now), in creation
        order; how many entities were ready."""
        if self._ready is None:
            self.wait(0.0)
        assert self._ready is not None
        plan, ready, events = self._ready
        self._ready = None
        n = 0
        for handler in events:
            with handler:  # in use while taken, as rclpy's executor takes an event
                taken = handler._EventHandler__event.take_event()
            if taken is not None:
                handler.callback(taken)
                n += 1
        if ready:
            if len(ready) > 1:  # in creation order: the tables' order
                rank = plan.rank
                ready.sort(key=lambda pointer: rank.get(pointer, -1))
            for pointer in ready:
                take = plan.takers.get(pointer)
                if take is not None:  # None: a callback destroyed its entity
                    take()
                    n += 1
        return n

    def close(self) -> None:
        """Destroy every rcl node and shut the context down."""
        if self._closed:
            return
        self._closed = True
        for node in self._nodes.values():
            node.destroy_node()
        self._nodes.clear()
        self._guard.destroy_when_not_in_use()
        if self.context.ok():
            rclpy.shutdown(context=self.context)
