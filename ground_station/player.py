"""Plays a rosbag2 MCAP back onto the topics (``ros2 bag play``): each message is written,
as the CDR it was recorded as, at its recorded time offset, in the executor's time. The
caller paces (or not) between :meth:`BagPlayer.step` calls."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from ground_station.bag import find_mcap
from ground_station.errors import BagError
from ground_station.topic_tap import TAP_QOS
from runtime import Endpoint
from runtime.executor import DeterministicExecutor
from runtime.transport import Writer


class BagPlayer:
    """Replays ``bag`` into ``executor``'s transport; time 0 is the bag's first message."""

    def __init__(self, bag: Path, executor: DeterministicExecutor) -> None:
        self.path = find_mcap(bag)
        self._executor = executor
        self._file = self.path.open("rb")
        try:
            self._reader = make_reader(self._file)
            self._messages: Iterator[tuple[Any, Any, Any]] = self._reader.iter_messages(
                log_time_order=True)
        except Exception as exc:
            self._file.close()
            raise BagError(f"cannot read {self.path}: {exc}; run quadmission bag repair "
                           f"first if the recording was killed") from None
        self._writers: dict[int, Writer] = {}
        self._start_ns: int | None = None
        self._pending: tuple[Any, Any, Any] | None = None
        self.played = 0

    def next_offset_ns(self) -> int | None:
        """When (from the bag's start) the next message is due; None at the end."""
        if self._pending is None:
            self._pending = next(self._messages, None)
            if self._pending is None:
                return None
        message = self._pending[2]
        if self._start_ns is None:
            self._start_ns = message.log_time
        return int(message.log_time - self._start_ns)

    def step(self) -> bool:
        """Write the next message (advancing the executor to its time); False at the end."""
        offset = self.next_offset_ns()
        if offset is None or self._pending is None:
            return False
        schema, channel, message = self._pending
        self._pending = None
        now = self._executor.now().nanoseconds
        self._executor.spin_until(max(now, offset))
        writer = self._writers.get(channel.id)
        if writer is None:
            writer = self._executor.context.transport.create_writer(
                Endpoint(channel.topic, schema.name, TAP_QOS))
            self._writers[channel.id] = writer
        writer.write(bytes(message.data))
        self.played += 1
        return True

    def close(self) -> None:
        for writer in self._writers.values():
            writer.close()
        self._file.close()


__all__ = ["BagPlayer"]
