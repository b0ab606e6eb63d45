"""The event loop a node's entities schedule their callbacks on."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from runtime.clock import Clock

#: (node name, entity kind, entity name): what a callback belongs to, for traces and logs.
Label = tuple[str, str, str]


@dataclass(eq=False)
class Handle:
    """A scheduled callback; ``cancel()`` stops it from running."""

    callback: Callable[[], None]
    label: Label
    cancelled: bool = field(default=False)

    def cancel(self) -> None:
        self.cancelled = True


class EventLoop(Protocol):
    """What entities need from an executor: time, and callbacks now or at a time."""

    @property
    def clock(self) -> Clock: ...

    def call_at(self, t_ns: int, callback: Callable[[], None], label: Label) -> Handle: ...

    def call_soon(self, callback: Callable[[], None], label: Label) -> Handle: ...

    def lateness_ns(self) -> int:
        """How far the host's clock is past the callback running now (its due time, the
        clock's): 0 in simulated time, where every callback runs at its time; on the wall
        clock, how late it started plus how long it has run."""
        ...
