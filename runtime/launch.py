"""Launch descriptions: which nodes to start, with what parameters and remappings."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from runtime.errors import LaunchError
from runtime.executor import DeterministicExecutor
from runtime.node import Node
from runtime.parameters import load_yaml, yaml_syntax_problem

NodeFactory = Callable[..., Node]


@dataclass(frozen=True)
class NodeSpec:
    """One node to start: ``factory`` is a Node subclass or ``"package.module:Class"``."""

    factory: str | NodeFactory
    name: str | None = None
    namespace: str = ""
    parameters: Mapping[str, Any] = field(default_factory=dict)
    remappings: Mapping[str, str] = field(default_factory=dict)

    def resolve_factory(self) -> NodeFactory:
        if not isinstance(self.factory, str):
            return self.factory
        module_name, sep, attr = self.factory.partition(":")
        if not sep or not module_name or not attr:
            raise LaunchError(f"factory {self.factory!r}: expected 'package.module:Class'")
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:
            raise LaunchError(
                f"factory {self.factory!r}: cannot import {module_name}: {exc}"
            ) from None
        try:
            factory: NodeFactory = getattr(module, attr)
        except AttributeError:
            raise LaunchError(f"factory {self.factory!r}: {module_name} has no {attr}") from None
        return factory


@dataclass(frozen=True)
class LaunchDescription:
    """An ordered list of nodes; they are created, and so run, in this order."""

    nodes: Sequence[NodeSpec]

    @classmethod
    def from_yaml(cls, path: Path) -> LaunchDescription:
        """Read ``nodes: [{factory, name, namespace, parameters, remappings}, ...]``."""
        try:
            doc = load_yaml(Path(path).read_text(encoding="utf-8")) or {}
        except OSError as exc:
            raise LaunchError(f"{path}: cannot read: {exc.strerror or exc}") from None
        except yaml.YAMLError as exc:
            raise LaunchError(f"{path}: {yaml_syntax_problem(exc)}") from None
        if not isinstance(doc, Mapping) or set(doc) != {"nodes"}:
            raise LaunchError(f"{path}: expected exactly one top-level key 'nodes'")
        allowed = {"factory", "name", "namespace", "parameters", "remappings"}
        specs = []
        for i, entry in enumerate(doc["nodes"] or []):
            if not isinstance(entry, Mapping):
                raise LaunchError(f"{path}: nodes[{i}]: expected a mapping")
            unknown = sorted(set(entry) - allowed)
            if unknown:
                raise LaunchError(f"{path}: nodes[{i}]: unknown key {unknown[0]!r}")
            if "factory" not in entry:
                raise LaunchError(f"{path}: nodes[{i}]: missing 'factory'")
            specs.append(NodeSpec(**entry))
        return cls(tuple(specs))


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
