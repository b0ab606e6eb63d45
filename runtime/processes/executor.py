"""The executor of a node process: the same event loop, in real time.

:class:`ClockedExecutor` is the deterministic executor's loop driven from outside: samples
come from a process transport (ROS 2: rclpy on Fast DDS; taken in this thread, handed to
the nodes' queues), and time comes from ``/clock`` (``use_sim_time``, as a ROS 2 node in a
simulation: timers fire when the simulator's clock passes them) or from the host's
clock. Node code is the same as in process; only who moves the clock differs.

Between two ``/clock`` samples the time is interpolated at the rate the clock has been
running (simulated over wall time), at most one ``/clock`` interval ahead of the last
sample, so it never passes the next one: a message is stamped when it arrives, not up
to a whole tick earlier (the time-sync exchange needs that resolution).

In a launch's lockstep the executor also reports the simulated time it has reached
(:meth:`ClockedExecutor.report_reached`): after it has run what was due, whenever its clock
has passed the next multiple of the report period, and at once when a ``/clock`` comes
again (the simulator waiting for it). A report is written straight on the transport, as
``/clock`` is read from it: no node, timer or message object in between.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Protocol, runtime_checkable

from interfaces import graph
from runtime.executor import DEFAULT_CONFIG_DIR, DeterministicExecutor, _Default
from runtime.loop import Handle, Label
from runtime.node import Node
from runtime.processes.callback_stats import CallbackStats
from runtime.processes.lockstep import clock_cdr, clock_ns
from runtime.transport import Endpoint, Reader, RequestId, Transport, Writer

__all__ = ["ClockedExecutor", "ParameterMirror", "ProcessTransport", "TakeTimer", "TimeFollower"]

_POLL_S = 0.05  # longest wait before looking at the stop condition again [s]


class ProcessTransport(Transport, Protocol):
    """A transport whose samples a process takes in its own thread: :meth:`wait` blocks
    until something arrived (or :meth:`wake`, from any thread or a signal handler),
    :meth:`dispatch` hands what arrived to the readers' callbacks."""

    def wait(self, timeout_s: float) -> bool: ...

    def wake(self) -> None: ...

    def dispatch(self) -> int: ...

    def close(self) -> None: ...


@runtime_checkable
class TimeFollower(Protocol):
    """A transport with clocks of its own (rcl nodes'), moved to each ``/clock`` sample."""

    def set_time(self, t_ns: int) -> None: ...


@runtime_checkable
class TakeTimer(Protocol):
    """A transport that tells how long each message waited to be taken (per node, ns)."""

    take_observer: Callable[[str, int], None] | None


@runtime_checkable
class ParameterMirror(Protocol):
    """A transport whose nodes show our nodes' parameters to foreign tools (those declared
    later too); mirroring a node a second time changes nothing."""

    def mirror_parameters(self, node: Node) -> None: ...


class ClockedExecutor(DeterministicExecutor):
    """Runs one process's nodes on a :class:`ProcessTransport`, following ``/clock`` or the
    host's clock. ``spin(until=...)`` returns when ``until()`` holds or :meth:`stop` is
    called (from a signal handler too)."""

    def __init__(self, transport: ProcessTransport, *, use_sim_time: bool = True,
                 config_dir: Path | _Default | None = DEFAULT_CONFIG_DIR) -> None:
        super().__init__(start_ns=0 if use_sim_time else time.time_ns(),
                         config_dir=config_dir, transport=transport)
        self.process_transport = transport
        self.use_sim_time = use_sim_time
        self._clock_ns: int | None = None
        self._clock_wall_ns = 0  # host monotonic time the last /clock arrived
        self._clock_step_ns = 0  # simulated time between the last two /clock samples
        self._clock_rate = 0.0  # simulated ns per wall ns, smoothed
        self._stopping = False
        self._clock_reader: Reader | None = None
        self._follower = transport if isinstance(transport, TimeFollower) else None
        self._reports: Writer | None = None  # the lockstep's (report_reached)
        self._report_period_ns = 0
        self._next_report_ns = 0  # the next report once the clock has reached this
        self.callback_stats: CallbackStats | None = None  # keep_callback_stats
        # a call_soon handle -> the host's ns when it was made due (a cancelled one stays:
        # seldom, and a few bytes)
        self._soon_ns: dict[Handle, int] = {}

    def keep_callback_stats(self) -> CallbackStats:
        """From now on, time each callback against the host's clock (on the wall clock
        only: under ``use_sim_time`` a callback's due time is simulated) and each
        message's take, per node: :mod:`runtime.processes.callback_stats`. Call it before
        the nodes are made (their readers then time their takes)."""
        if self.use_sim_time:
            raise ValueError("callback statistics need the wall clock (not use_sim_time)")
        self.callback_stats = stats = CallbackStats()
        if isinstance(self.process_transport, TakeTimer):
            self.process_transport.take_observer = stats.take
        return stats

    def lateness_ns(self) -> int:
        if self.use_sim_time:
            return 0  # the lockstep runs each callback at its simulated time
        return max(0, time.time_ns() - self.now_ns())

    def catch_up(self) -> None:
        """On the wall clock, move the clock to the host's time, running what is due: after
        a long start-up (imports), so that the nodes made next count their timers from the
        host's time, not from when this executor was made. Under ``use_sim_time`` it does
        nothing: ``/clock`` moves the clock."""
        if not self.use_sim_time:
            self.spin_until(self._target_ns())

    def call_soon(self, callback: Callable[[], None], label: Label) -> Handle:
        handle = super().call_soon(callback, label)
        if self.callback_stats is not None:  # due now on the host's clock: the clock may
            self._soon_ns[handle] = time.time_ns()  # still be at an earlier callback's
        return handle

    def _run(self, t_ns: int, handle: Handle) -> None:
        stats = self.callback_stats
        if stats is None:
            super()._run(t_ns, handle)
            return
        due = self._soon_ns.pop(handle, t_ns)  # a timer's time, or when it was made due
        start = time.time_ns()
        super()._run(t_ns, handle)
        stats.callback(handle.label[0], start - due, time.time_ns() - start)

    def follow_clock(self) -> None:
        """Subscribe to ``/clock`` (with ``use_sim_time``). The simulator starts its clock
        once every node process has subscribed, so a process calls this when its nodes
        exist: no simulated time passes while it boots."""
        if self.use_sim_time and self._clock_reader is None:
            self._clock_reader = self.process_transport.create_reader(
                Endpoint(graph.CLOCK.name, graph.CLOCK.type, graph.CLOCK.subscriber_qos),
                self._on_clock)

    def report_reached(self, writer: Writer, period_s: float) -> None:
        """Lockstep: write the simulated time this process has reached on ``writer`` (a
        ``Clock`` message) each time its clock passes a multiple of ``period_s``, and at
        once when a ``/clock`` is not newer than the last. The simulator sends ``/clock``
        again while it waits; the periodic reports alone, on a simulated time that no
        longer moves, would not come again, and one written before the simulator's reader
        matched is lost (volatile)."""
        self._reports = writer
        self._report_period_ns = round(period_s * 1e9)
        self._next_report_ns = 0

    def _report(self) -> None:
        assert self._reports is not None
        t_ns = self.now_ns()
        self._reports.write(clock_cdr(t_ns))
        self._next_report_ns = (t_ns // self._report_period_ns + 1) * self._report_period_ns

    def _on_clock(self, data: bytes, _request_id: RequestId | None) -> None:
        t_ns = clock_ns(data)
        wall_ns = time.monotonic_ns()
        if self._clock_ns is None:
            self._clock_ns, self._clock_wall_ns = t_ns, wall_ns
        elif t_ns > self._clock_ns:
            step, wall_step = t_ns - self._clock_ns, wall_ns - self._clock_wall_ns
            if wall_step > 0:
                rate = step / wall_step
                self._clock_rate = rate if self._clock_rate == 0.0 else (
                    0.9 * self._clock_rate + 0.1 * rate)
            self._clock_ns, self._clock_wall_ns, self._clock_step_ns = t_ns, wall_ns, step
        elif self._reports is not None:
            self._report()
        if self._follower is not None:
            self._follower.set_time(t_ns)

    def _target_ns(self) -> int:
        """Where the clock should be now (never behind where it is)."""
        if not self.use_sim_time:
            return max(time.time_ns(), self.now_ns())
        if self._clock_ns is None:
            return self.now_ns()
        ahead = (time.monotonic_ns() - self._clock_wall_ns) * self._clock_rate
        return max(self._clock_ns + min(self._clock_step_ns, round(ahead)), self.now_ns())

    def wait_for_clock(self, timeout_s: float) -> bool:
        """Follow ``/clock``, wait for its first sample and move the clock there. False on
        timeout."""
        if not self.use_sim_time:
            return True
        self.follow_clock()
        deadline = time.monotonic() + timeout_s
        while self._clock_ns is None and not self._stopping:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self.process_transport.wait(min(left, _POLL_S))
            self.process_transport.dispatch()
        if self._clock_ns is not None:
            self.spin_until(self._clock_ns)
        return self._clock_ns is not None

    def stop(self) -> None:
        """Make :meth:`spin` return soon (safe from a signal handler)."""
        self._stopping = True
        self.process_transport.wake()

    @property
    def stopping(self) -> bool:
        return self._stopping

    def spin_once_realtime(self) -> None:
        """Wait for data or the next due callback, take what arrived, run what is due."""
        timeout = _POLL_S
        if not self.use_sim_time:
            t_next = self.next_event_ns()
            if t_next is not None:
                timeout = min(timeout, max(0.0, (t_next - time.time_ns()) / 1e9))
        self.process_transport.wait(timeout)
        self.spin_until(self._target_ns())  # arrival time
        self.process_transport.dispatch()
        self.spin_until(self._target_ns())
        if self._reports is not None and self.now_ns() >= self._next_report_ns:
            self._report()

    def spin(self, until: Callable[[], bool] | None = None) -> None:
        """Run until ``until()`` holds or :meth:`stop` is called."""
        while not self._stopping and not (until is not None and until()):
            self.spin_once_realtime()
