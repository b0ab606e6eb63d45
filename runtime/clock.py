"""Time and duration as integer nanoseconds, and the clocks nodes read."""

from __future__ import annotations

import time as _time
from dataclasses import dataclass
from enum import Enum
from typing import Any, Protocol

import interfaces
from runtime.errors import ClockError

NS_PER_S = 1_000_000_000


def seconds_to_ns(seconds: float) -> int:
    """Seconds (float) to integer nanoseconds, rounded to the nearest nanosecond."""
    return round(seconds * NS_PER_S)


@dataclass(frozen=True, order=True)
class Duration:
    """A span of time in integer nanoseconds."""

    nanoseconds: int = 0

    @classmethod
    def from_seconds(cls, seconds: float) -> Duration:
        return cls(seconds_to_ns(seconds))

    @property
    def seconds(self) -> float:
        return self.nanoseconds / NS_PER_S

    def to_msg(self) -> Any:
        sec, nsec = divmod(self.nanoseconds, NS_PER_S)
        return interfaces.new("builtin_interfaces/msg/Duration", sec=sec, nanosec=nsec)


@dataclass(frozen=True, order=True)
class Time:
    """A point in time on one clock, in integer nanoseconds since that clock's epoch."""

    nanoseconds: int = 0

    @classmethod
    def from_seconds(cls, seconds: float) -> Time:
        return cls(seconds_to_ns(seconds))

    @classmethod
    def from_msg(cls, msg: Any) -> Time:
        """From a builtin_interfaces/msg/Time."""
        return cls(int(msg.sec) * NS_PER_S + int(msg.nanosec))

    @property
    def seconds(self) -> float:
        return self.nanoseconds / NS_PER_S

    def to_msg(self) -> Any:
        """As a builtin_interfaces/msg/Time."""
        sec, nsec = divmod(self.nanoseconds, NS_PER_S)
        return interfaces.new("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec)

    def __add__(self, other: Duration) -> Time:
        return Time(self.nanoseconds + other.nanoseconds)

    def __sub__(self, other: Time) -> Duration:
        return Duration(self.nanoseconds - other.nanoseconds)


class ClockType(Enum):
    """Which time a clock reads: the simulator's (ROS_TIME) or the host's (SYSTEM_TIME)."""

    ROS_TIME = "ros_time"
    SYSTEM_TIME = "system_time"


class Clock(Protocol):
    """Anything that tells the time."""

    clock_type: ClockType

    def now(self) -> Time: ...


class SimClock:
    """Simulated time, advanced only by the executor that owns it."""

    clock_type = ClockType.ROS_TIME

    def __init__(self, start_ns: int = 0) -> None:
        self._now_ns = start_ns

    def now(self) -> Time:
        return Time(self._now_ns)

    @property
    def nanoseconds(self) -> int:
        return self._now_ns

    def advance_to(self, t_ns: int) -> None:
        """Move time forward to ``t_ns``; time never runs backwards."""
        if t_ns < self._now_ns:
            raise ClockError(f"cannot move the clock back from {self._now_ns} ns to {t_ns} ns")
        self._now_ns = t_ns


class WallClock:
    """The host's real-time clock (``SYSTEM_TIME``), for what runs on the host's time."""

    clock_type = ClockType.SYSTEM_TIME

    def now(self) -> Time:
        return Time(_time.time_ns())
