"""The context nodes are created in (rclpy's ``Context``): an event loop, a transport and
where the nodes' configs live."""

from __future__ import annotations

from collections.abc import Coroutine
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

from runtime.future import Task
from runtime.loop import EventLoop, Label
from runtime.transport import Transport

__all__ = ["Context"]

N = TypeVar("N")
T = TypeVar("T")


@dataclass
class Context(Generic[N]):
    """What nodes are created in: an event loop, a transport and where configs live.

    ``nodes`` are the live nodes created in it (a :class:`runtime.node.Node` joins when it
    is made and leaves on ``destroy_node``); ``N``, their class, is a parameter so that
    this module needs nothing of the node's.
    """

    loop: EventLoop
    transport: Transport
    config_dir: Path | None = None
    nodes: list[N] = field(default_factory=list)

    def create_task(self, coro: Coroutine[Any, Any, T], label: Label) -> Task[T]:
        return Task(coro, self.loop, label)
