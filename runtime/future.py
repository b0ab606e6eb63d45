"""Futures and coroutine tasks, in the shape of rclpy's, driven by the executor."""

from __future__ import annotations

from collections.abc import Callable, Coroutine, Generator
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from runtime.errors import FutureError

if TYPE_CHECKING:
    from runtime.loop import EventLoop

T = TypeVar("T")

_PENDING = "pending"
_DONE = "done"
_CANCELLED = "cancelled"


class Future(Generic[T]):
    """The outcome of an asynchronous operation (a service call, a goal, a sleep).

    Done-callbacks run through the event loop when one is attached, so they keep the
    executor's callback order; ``await future`` works inside a Task.
    """

    def __init__(self, loop: EventLoop | None = None) -> None:
        self._loop = loop
        self._state = _PENDING
        self._result: T | None = None
        self._exception: BaseException | None = None
        self._callbacks: list[Callable[[Future[T]], None]] = []

    def done(self) -> bool:
        return self._state != _PENDING

    def cancelled(self) -> bool:
        return self._state == _CANCELLED

    def result(self) -> T:
        """The result; raises the stored exception, or FutureError if not done."""
        if self._state == _PENDING:
            raise FutureError("the future is not done yet")
        if self._state == _CANCELLED:
            raise FutureError("the future was cancelled")
        if self._exception is not None:
            raise self._exception
        return self._result  # type: ignore[return-value]

    def exception(self) -> BaseException | None:
        if self._state == _PENDING:
            raise FutureError("the future is not done yet")
        return self._exception

    def set_result(self, result: T) -> None:
        self._finish(_DONE, result, None)

    def set_exception(self, exception: BaseException) -> None:
        self._finish(_DONE, None, exception)

    def cancel(self) -> bool:
        if self.done():
            return False
        self._finish(_CANCELLED, None, None)
        return True

    def add_done_callback(self, callback: Callable[[Future[T]], None]) -> None:
        if self.done():
            self._schedule(callback)
        else:
            self._callbacks.append(callback)

    def _finish(self, state: str, result: T | None, exc: BaseException | None) -> None:
        if self.done():
            raise FutureError("the future is already done")
        self._state, self._result, self._exception = state, result, exc
        callbacks, self._callbacks = self._callbacks, []
        for cb in callbacks:
            self._schedule(cb)

    def _schedule(self, callback: Callable[[Future[T]], None]) -> None:
        if self._loop is None:
            callback(self)
        else:
            self._loop.call_soon(lambda: callback(self), ("", "future", ""))

    def __await__(self) -> Generator[Future[T], None, T]:
        if not self.done():
            yield self
        return self.result()


def first_done(*futures: Future[Any], loop: EventLoop | None = None) -> Future[None]:
    """A future done as soon as any of ``futures`` is (``await first_done(a, b)``)."""
    either: Future[None] = Future(loop)

    def wake(_f: Future[Any]) -> None:
        if not either.done():
            either.set_result(None)

    for future in futures:
        future.add_done_callback(wake)
    return either


class Task(Future[T]):
    """Runs a coroutine on the loop; each ``await`` of a Future suspends it until done."""

    def __init__(
        self, coro: Coroutine[Any, Any, T], loop: EventLoop, label: tuple[str, str, str]
    ) -> None:
        super().__init__(loop)
        self._coro = coro
        self._label = label
        loop.call_soon(self._step, label)

    def cancel(self) -> bool:
        """Cancel the task: its coroutine is closed and never resumed."""
        if self.done():
            return False
        self._coro.close()
        return super().cancel()

    def _step(self) -> None:
        if self.done():  # cancelled while it waited
            return
        try:
            awaited = self._coro.send(None)
        except StopIteration as stop:
            self.set_result(stop.value)
            return
        except BaseException as exc:  # the task's error is its result, and the executor's
            self.set_exception(exc)
            raise
        if not isinstance(awaited, Future):
            error = TypeError(f"a Task can only await runtime Futures, got {awaited!r}")
            self._coro.close()
            self.set_exception(error)
            raise error
        awaited.add_done_callback(lambda _f: self._step())
