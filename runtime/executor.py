"""The in-process deterministic executor.

One thread, simulated time. Every callback (timer, message, service, future, task step)
is an event at a time; events run in (time, order of scheduling) order, and the clock
jumps to each event's time. Nothing sleeps: a caller advances time with ``spin_until``.
The same nodes, parameters and inputs therefore give the same callback trace.
"""

from __future__ import annotations

import concurrent.futures
import heapq
import itertools
import os
from collections.abc import Callable, Coroutine
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, TypeVar

from runtime.clock import Clock, SimClock, Time, seconds_to_ns
from runtime.context import Context
from runtime.errors import ClockError
from runtime.future import Future, Task
from runtime.loop import Handle, Label
from runtime.node import Node
from runtime.parameters import config_dir as default_config_dir
from runtime.transport import InProcessTransport, Transport

T = TypeVar("T")


class _Default(Enum):
    CONFIG_DIR = "the config folder"


DEFAULT_CONFIG_DIR = _Default.CONFIG_DIR
"""``config_dir`` default: :func:`runtime.parameters.config_dir`, read when the executor is made."""


@dataclass(frozen=True)
class TraceEntry:
    """One callback the executor ran: when, and what it belongs to."""

    t_ns: int
    node: str
    kind: str
    name: str


THREADS_VARIABLE = "QUADMISSION_THREADS"
"""Set to 0, work offloaded by nodes and the simulator's cameras run in line: the same run,
on one core (for comparison and for debugging)."""


def threads_allowed() -> bool:
    """Whether work may leave the main thread (:data:`THREADS_VARIABLE` is not 0)."""
    return os.environ.get(THREADS_VARIABLE, "1").strip() != "0"


class DeterministicExecutor:
    """Runs every node of its context in one thread, in simulated time.

    >>> ex = DeterministicExecutor()
    >>> # node = MyNode(context=ex.context); ex.add_node(node)
    >>> ex.spin_for(1.0)  # run one simulated second
    """

    def __init__(
        self,
        *,
        start_ns: int = 0,
        config_dir: Path | _Default | None = DEFAULT_CONFIG_DIR,
        transport: Transport | None = None,
        record_trace: bool = False,
        worker_thread: bool | None = None,
    ) -> None:
        self._clock = SimClock(start_ns)
        self.worker_thread = threads_allowed() if worker_thread is None else worker_thread
        """Work offloaded by nodes runs on a worker thread (False: in line, for comparison;
        default: :func:`threads_allowed`)."""
        self._worker: concurrent.futures.ThreadPoolExecutor | None = None
        self._heap: list[tuple[int, int, Handle]] = []
        self._order = itertools.count()
        self._nodes: list[Node] = []
        self._stopped: frozenset[str] = frozenset()  # nodes no longer executed
        self.trace: list[TraceEntry] | None = [] if record_trace else None
        self.callbacks_run = 0
        self.context: Context[Node] = Context(
            loop=self,
            transport=transport or InProcessTransport(),
            config_dir=default_config_dir() if isinstance(config_dir, _Default) else config_dir,
        )

    # EventLoop ---------------------------------------------------------------------------
    @property
    def clock(self) -> Clock:
        return self._clock

    def call_at(self, t_ns: int, callback: Callable[[], None], label: Label) -> Handle:
        if t_ns < self._clock.nanoseconds:
            raise ClockError(
                f"cannot schedule {label} at {t_ns} ns, before now ({self._clock.nanoseconds} ns)"
            )
        handle = Handle(callback, label)
        heapq.heappush(self._heap, (t_ns, next(self._order), handle))
        return handle

    def call_soon(self, callback: Callable[[], None], label: Label) -> Handle:
        # call_at at the clock's time, never in the past: no check
        handle = Handle(callback, label)
        heapq.heappush(self._heap, (self._clock.nanoseconds, next(self._order), handle))
        return handle

    def lateness_ns(self) -> int:
        return 0  # simulated time: each callback runs at its time

    def start_work(self, work: Callable[[], T]) -> concurrent.futures.Future[T]:
        """Start ``work`` for :meth:`runtime.node.Node.offload`: on the worker thread (one,
        so work runs in the order it was started), or at once in line when the executor
        was made with ``worker_thread=False``: the same results either way."""
        if not self.worker_thread:
            done: concurrent.futures.Future[T] = concurrent.futures.Future()
            try:
                done.set_result(work())
            except Exception as exc:
                done.set_exception(exc)
            return done
        if self._worker is None:
            self._worker = concurrent.futures.ThreadPoolExecutor(
                1, thread_name_prefix="executor_work")
        return self._worker.submit(work)

    def shutdown(self) -> None:
        """Wait for the work started and stop the worker thread (made again if needed)."""
        if self._worker is not None:
            worker, self._worker = self._worker, None
            worker.shutdown(wait=True)

    # nodes -------------------------------------------------------------------------------
    def add_node(self, node: Node) -> None:
        """Take a node into this executor; its YAML must not name undeclared parameters.

        Unlike rclpy, callbacks belong to the context: a node's timers, subscriptions and
        tasks run from their creation until ``destroy_node``, whether or not it was added
        here; adding checks its parameters and lists it, removing only unlists it.
        """
        node.check_parameters_declared()
        if node not in self._nodes:
            self._nodes.append(node)

    def remove_node(self, node: Node) -> None:
        if node in self._nodes:
            self._nodes.remove(node)

    def get_nodes(self) -> list[Node]:
        return list(self._nodes)

    def stop_node(self, name: str) -> None:
        """Stop executing the node named ``name``, as if its process had died (a fault):
        every callback of it (timers, messages, services, actions, tasks) due from now on
        is dropped; the rest of the graph runs on. ``name`` must be a node of the context."""
        names = sorted(n.get_name() for n in self.context.nodes)
        if name not in names:
            raise ValueError(f"no node {name!r} to stop (nodes: {', '.join(names)})")
        self._stopped = self._stopped | {name}

    def restart_node(self, name: str) -> Node:
        """Start the stopped node ``name`` again, as its process respawned: the dead
        instance is destroyed (its endpoints leave the graph, its callbacks still due are
        dropped) and a fresh one (:meth:`Node.respawn`) is made now and added. The fresh
        node has its parameters and nothing else; what it knew comes from the topics."""
        if name not in self._stopped:
            raise ValueError(f"node {name!r} is not stopped (stopped: "
                             f"{', '.join(sorted(self._stopped)) or 'none'})")
        old = next(n for n in self.context.nodes if n.get_name() == name)
        for _, _, handle in self._heap:  # the dead one's: never run, even once restarted
            if handle.label[0] == name:
                handle.cancel()
        old.destroy_node()
        self.remove_node(old)
        self._stopped = self._stopped - {name}
        node = old.respawn()
        self.add_node(node)
        return node

    @property
    def stopped_nodes(self) -> frozenset[str]:
        return self._stopped

    def create_task(self, coro: Coroutine[Any, Any, T]) -> Task[T]:
        return Task(coro, self, ("", "task", getattr(coro, "__qualname__", "")))

    # time --------------------------------------------------------------------------------
    def now(self) -> Time:
        return self._clock.now()

    def now_ns(self) -> int:
        """The clock's time in nanoseconds (``now().nanoseconds`` without making a Time)."""
        return self._clock.nanoseconds

    def next_event_ns(self) -> int | None:
        """When the next pending callback is due, or None when nothing is scheduled."""
        while self._heap and self._heap[0][2].cancelled:
            heapq.heappop(self._heap)
        return self._heap[0][0] if self._heap else None

    def _run(self, t_ns: int, handle: Handle) -> None:
        self._clock.advance_to(t_ns)
        if self._stopped and handle.label[0] in self._stopped:
            return  # a stopped node's callback: dropped
        if self.trace is not None:
            self.trace.append(TraceEntry(t_ns, *handle.label))
        self.callbacks_run += 1
        handle.callback()

    def spin_once(self, timeout_sec: float | None = None) -> bool:
        """Run the next callback if it is due within ``timeout_sec``; True if one ran."""
        t_next = self.next_event_ns()
        if t_next is None:
            return False
        if timeout_sec is not None and t_next > self._clock.nanoseconds + seconds_to_ns(
            timeout_sec
        ):
            self._clock.advance_to(self._clock.nanoseconds + seconds_to_ns(timeout_sec))
            return False
        t_ns, _, handle = heapq.heappop(self._heap)
        self._run(t_ns, handle)
        return True

    def spin_until(self, t: Time | int) -> None:
        """Run every callback due at or before ``t``, then set the clock to ``t``."""
        t_end = t if type(t) is int else t.nanoseconds if isinstance(t, Time) else int(t)
        clock = self._clock
        if t_end < clock.nanoseconds:
            raise ClockError(f"cannot spin back to {t_end} ns from {clock.nanoseconds} ns")
        heap = self._heap
        while heap:  # next_event_ns and spin_once written out: this runs twice a world tick
            t_ns, _, handle = heap[0]
            if t_ns > t_end:
                break
            heapq.heappop(heap)
            if not handle.cancelled:
                self._run(t_ns, handle)
        if t_end != clock.nanoseconds:
            clock.advance_to(t_end)

    def spin_for(self, seconds: float) -> None:
        """Advance simulated time by ``seconds``, running everything due."""
        self.spin_until(self._clock.nanoseconds + seconds_to_ns(seconds))

    def spin_until_future_complete(
        self, future: Future[Any], timeout_sec: float | None = None
    ) -> bool:
        """Run callbacks until ``future`` is done or ``timeout_sec`` of simulated time
        passes (forever when None, as long as anything is scheduled). True if done."""
        deadline = (
            None if timeout_sec is None else self._clock.nanoseconds + seconds_to_ns(timeout_sec)
        )
        while not future.done():
            t_next = self.next_event_ns()
            if t_next is None or (deadline is not None and t_next > deadline):
                if deadline is not None:
                    self._clock.advance_to(deadline)
                return future.done()
            t_ns, _, handle = heapq.heappop(self._heap)
            self._run(t_ns, handle)
        return True
