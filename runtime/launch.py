"""Launch descriptions: which nodes to start, with what parameters and remappings.

A launch file lists ``nodes:``; it may add a ``simulator:`` (a factory that builds the
simulated world around an executor, see :class:`Simulation`) and put nodes in named
``process:`` groups (used when each group runs in its own process over ROS 2; in process,
groups are ignored). A node that has an ``exit_code`` attribute (:class:`Finishing`)
ends the launch when it sets it: the mission script says when the mission is over.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import yaml

from runtime.errors import LaunchError
from runtime.executor import DeterministicExecutor
from runtime.node import Node
from runtime.parameters import load_yaml, yaml_syntax_problem

NodeFactory = Callable[..., Node]


@runtime_checkable
class Finishing(Protocol):
    """A node that ends the launch: ``exit_code`` is None while it runs, then the code
    (0: done and succeeded) with ``exit_reason`` saying why, in one line."""

    exit_code: int | None
    exit_reason: str


@dataclass(frozen=True)
class SimulationResult:
    """How a simulation ended: an exit code (0 fine, 1 failed: a crash) and why."""

    exit_code: int
    reason: str


class Simulation(Protocol):
    """The simulated world a launch runs in: it steps the executor in lockstep.

    ``run`` steps until ``stop()`` holds or ``limit_s`` of simulated time passed, and
    calls ``tick(t_ns)`` at ``tick_hz`` of simulated time when given (the simulator process
    of a launch over processes publishes /clock, takes incoming samples and paces to real
    time there)."""

    def run(self, limit_s: float, stop: Callable[[], bool],
            tick: Callable[[int], None] | None = None,
            tick_hz: float = 1000.0) -> SimulationResult: ...


SimulationFactory = Callable[..., Simulation]


def _resolve(factory: str, what: str) -> Any:
    module_name, sep, attr = factory.partition(":")
    if not sep or not module_name or not attr:
        raise LaunchError(f"{what} {factory!r}: expected 'package.module:Class'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise LaunchError(f"{what} {factory!r}: cannot import {module_name}: {exc}") from None
    try:
        return getattr(module, attr)
    except AttributeError:
        raise LaunchError(f"{what} {factory!r}: {module_name} has no {attr}") from None


@dataclass(frozen=True)
class SimulatorSpec:
    """The simulator: ``factory(executor, **parameters)`` returns a :class:`Simulation`."""

    factory: str
    parameters: Mapping[str, Any] = field(default_factory=dict)

    def build(self, executor: DeterministicExecutor) -> Simulation:
        factory: SimulationFactory = _resolve(self.factory, "simulator")
        return factory(executor, **dict(self.parameters))


@dataclass(frozen=True)
class NodeSpec:
    """One node to start: ``factory`` is a Node subclass or ``"package.module:Class"``."""

    factory: str | NodeFactory
    name: str | None = None
    namespace: str = ""
    parameters: Mapping[str, Any] = field(default_factory=dict)
    remappings: Mapping[str, str] = field(default_factory=dict)
    process: str | None = None  # the process group over ROS 2 (default: its own)
    #: over ROS 2: start the node's process again when it dies (ROS 2 launch's ``respawn``),
    #: ``respawn_delay`` seconds later, at most ``respawn_max`` times (None: the default,
    #: :data:`runtime.processes.respawn.DEFAULT_RESPAWN_MAX`); in process they are ignored
    respawn: bool = False
    respawn_delay: float = 0.0
    respawn_max: int | None = None

    def process_name(self) -> str:
        """The group this node runs in over ROS 2: ``process``, else its own name."""
        if self.process:
            return self.process
        if self.name:
            return self.name
        return str(self.factory).rsplit(":", 1)[-1].lower()

    def resolve_factory(self) -> NodeFactory:
        if not isinstance(self.factory, str):
            return self.factory
        factory: NodeFactory = _resolve(self.factory, "factory")
        return factory


@dataclass(frozen=True)
class LaunchDescription:
    """An ordered list of nodes; they are created, and so run, in this order."""

    nodes: Sequence[NodeSpec]
    simulator: SimulatorSpec | None = None

    @classmethod
    def from_yaml(cls, path: Path) -> LaunchDescription:
        """Read ``nodes: [{factory, name, namespace, parameters, remappings, process,
        respawn, respawn_delay, respawn_max}, ...]`` and an optional ``simulator:
        {factory, parameters}``."""
        try:
            doc = load_yaml(Path(path).read_text(encoding="utf-8")) or {}
        except OSError as exc:
            raise LaunchError(f"{path}: cannot read: {exc.strerror or exc}") from None
        except yaml.YAMLError as exc:
            raise LaunchError(f"{path}: {yaml_syntax_problem(exc)}") from None
        if not isinstance(doc, Mapping) or "nodes" not in doc or set(doc) - {"nodes",
                                                                              "simulator"}:
            raise LaunchError(f"{path}: expected the top-level key 'nodes' "
                              "(and optionally 'simulator'), nothing else")
        simulator = None
        if doc.get("simulator") is not None:
            sim = doc["simulator"]
            if not isinstance(sim, Mapping) or "factory" not in sim or set(sim) - {
                    "factory", "parameters"}:
                raise LaunchError(f"{path}: simulator: expected {{factory, parameters}}")
            simulator = SimulatorSpec(str(sim["factory"]), dict(sim.get("parameters") or {}))
        allowed = {"factory", "name", "namespace", "parameters", "remappings", "process",
                   "respawn", "respawn_delay", "respawn_max"}
        specs = []
        for i, entry in enumerate(doc["nodes"] or []):
            if not isinstance(entry, Mapping):
                raise LaunchError(f"{path}: nodes[{i}]: expected a mapping")
            unknown = sorted(set(entry) - allowed)
            if unknown:
                raise LaunchError(f"{path}: nodes[{i}]: unknown key {unknown[0]!r}")
            if "factory" not in entry:
                raise LaunchError(f"{path}: nodes[{i}]: missing 'factory'")
            problem = _respawn_problem(entry)
            if problem:
                raise LaunchError(f"{path}: nodes[{i}]: {problem}")
            specs.append(NodeSpec(**entry))
        return cls(tuple(specs), simulator)


def _respawn_problem(entry: Mapping[str, Any]) -> str:
    """What is wrong with a node entry's respawn keys, or ''."""
    if not isinstance(entry.get("respawn", False), bool):
        return f"respawn: expected true or false, got {entry['respawn']!r}"
    delay = entry.get("respawn_delay", 0.0)
    if isinstance(delay, bool) or not isinstance(delay, int | float) or not 0 <= delay <= 3600:
        return f"respawn_delay: expected 0 to 3600 (s), got {delay!r}"
    count = entry.get("respawn_max")
    if count is not None and (isinstance(count, bool) or not isinstance(count, int)
                              or not 1 <= count <= 1000):
        return f"respawn_max: expected a count from 1 to 1000, got {count!r}"
    return ""


def launch(description: LaunchDescription, executor: DeterministicExecutor) -> list[Node]:
    """Create every node of ``description`` in ``executor``'s context and add it."""
    nodes = []
    for spec in description.nodes:
        factory = spec.resolve_factory()
        remappings = dict(spec.remappings)
        if spec.name:
            remappings["__node"] = spec.name
        node = factory(
            context=executor.context,
            namespace=spec.namespace,
            parameter_overrides=dict(spec.parameters),
            remappings=remappings,
        )
        executor.add_node(node)
        nodes.append(node)
    return nodes


def finishing(nodes: Sequence[Node]) -> tuple[Finishing, ...]:
    """The nodes that can end the launch. Found once: an ``isinstance`` against a Protocol
    costs microseconds, and a launch asks :func:`first_finished` at every step."""
    return tuple(node for node in nodes if isinstance(node, Finishing))


def first_finished(watched: Sequence[Finishing]) -> Finishing | None:
    """The first of ``watched`` that has finished (set its ``exit_code``), or None."""
    return next((node for node in watched if node.exit_code is not None), None)


def finished(nodes: Sequence[Node]) -> Finishing | None:
    """The first node that has finished (set its ``exit_code``), or None."""
    return first_finished(finishing(nodes))


@dataclass(frozen=True)
class LaunchOutcome:
    """How an in-process launch ended."""

    exit_code: int
    reason: str
    sim_time_s: float


def run_in_process(description: LaunchDescription, executor: DeterministicExecutor,
                   duration_s: float) -> LaunchOutcome:
    """Everything in one executor: the simulator (if any) steps it in lockstep with every
    node of the description, until a finishing node finishes, the simulation fails or
    ``duration_s`` of simulated time passes (exit code 0 then, reason ``time limit``)."""
    simulation = description.simulator.build(executor) if description.simulator else None
    nodes = launch(description, executor)
    if simulation is None:
        executor.spin_until(executor.now().nanoseconds + round(duration_s * 1e9))
        done = finished(nodes)
    else:
        watched = finishing(nodes)
        result = simulation.run(duration_s, stop=lambda: first_finished(watched) is not None)
        done = finished(nodes)
        if done is None and result.exit_code != 0:
            return LaunchOutcome(result.exit_code, result.reason, executor.now().seconds)
    if done is not None:
        assert done.exit_code is not None
        return LaunchOutcome(done.exit_code, done.exit_reason, executor.now().seconds)
    return LaunchOutcome(0, "time limit", executor.now().seconds)
