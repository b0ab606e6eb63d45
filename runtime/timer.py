"""A timer on the node's clock (rclpy's ``Timer``)."""

from __future__ import annotations

from collections.abc import Callable

from runtime.clock import seconds_to_ns
from runtime.entity import EntityNode
from runtime.errors import ClockError
from runtime.loop import Handle, Label

__all__ = ["Timer"]


class Timer:
    """Calls ``callback()`` every ``period`` of the node's clock, first one period after
    creation (as rclpy does). Fire times are start + k * period exactly: no drift. A call
    that ran late on the wall clock skips the periods it missed (as rcl's timers do)."""

    def __init__(self, node: EntityNode, period_sec: float, callback: Callable[[], None]) -> None:
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
        late = self._loop.lateness_ns()  # 0 but on the wall clock, behind (a busy process)
        if late >= self.timer_period_ns:  # the periods it missed are skipped, as rcl's
            self._count += late // self.timer_period_ns  # timers do: no burst to catch up
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

