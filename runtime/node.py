"""The node (rclpy's ``Node``): it makes the entities (publisher, subscription, service,
client, timer: one module each), runs tasks, sleeps and offloaded work on its context's
loop, and holds its parameters (declared from the node's YAML and launch overrides)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Coroutine, Mapping, Sequence
from enum import Enum
from typing import Any, TypeVar

import interfaces
from interfaces.qos import QoSProfile, as_qos, qos_profile_services_default
from runtime.client import Client
from runtime.clock import Clock, Time, seconds_to_ns
from runtime.context import Context
from runtime.errors import ParameterError
from runtime.future import Future, Task
from runtime.logger import NodeLogger
from runtime.loop import Handle
from runtime.names import resolve_name, stable_guid, validate_namespace, validate_node_name
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
from runtime.publisher import Publisher
from runtime.service import Service
from runtime.subscription import Subscription
from runtime.timer import Timer

__all__ = ["Node"]

T = TypeVar("T")
P = TypeVar("P")


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
        context: Context[Node],
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
        born_ns = context.loop.clock.now().nanoseconds
        #: "" for a node made at the start; a node made later (a restart of a dead one)
        #: gets its own identifiers: the same name would give the dead one's again
        self.instance_tag = "" if born_ns == 0 else f"@{born_ns}"
        self._entities: list[Any] = []
        self._tasks: list[Task[Any]] = []
        self._sleeps: set[Handle] = set()  # pending sleeps, cancelled on destroy_node
        self._logger = NodeLogger(self.get_fully_qualified_name().lstrip("/"), context.loop.clock)
        self._parameters: dict[str, Parameter] = {}
        self._descriptors: dict[str, ParameterDescriptor] = {}
        self._on_set_callbacks: list[Callable[[list[Parameter]], SetParametersResult]] = []
        self._post_set_callbacks: list[Callable[[list[Parameter]], None]] = []
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
        return stable_guid(self.get_fully_qualified_name() + self.instance_tag, kind, name,
                           str(self._guid_counter))

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

    def respawn(self) -> Node:
        """A fresh instance of this node in its context, as a restarted process makes it:
        the same class, name, namespace, parameter overrides and remappings, and nothing
        else of this one (its state comes back from topics and parameters). A subclass
        whose constructor takes more than those overrides this."""
        remappings = dict(self._remappings) | {"__node": self._name}
        return type(self)(context=self.context, namespace=self._namespace,  # type: ignore[call-arg]
                          parameter_overrides=dict(self._overrides), remappings=remappings)

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
        else ``value``. Type comes from the descriptor or the default. The post-set
        callbacks hear it (rclpy's do)."""
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
        for post in self._post_set_callbacks:
            post([param])
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

    def add_post_set_parameters_callback(
        self, callback: Callable[[list[Parameter]], None]
    ) -> None:
        """Call ``callback([parameter])`` after each parameter is declared or set, with its
        new value (rclpy's): whoever set it, the node itself or a tool through the
        transport."""
        self._post_set_callbacks.append(callback)

    def set_parameters(self, parameters: Sequence[Parameter]) -> list[SetParametersResult]:
        """Change declared parameters at run time, each validated like a declaration; the
        on-set callbacks may refuse a change, the post-set callbacks hear each one made."""
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
                for post in self._post_set_callbacks:
                    post([new])
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

