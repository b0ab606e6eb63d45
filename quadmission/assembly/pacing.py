"""Real-time pacing: a world part that holds the simulation to X times real time.

Without it the simulator runs as fast as the host allows (the default: tests and
batch runs). With ``--rtf 1`` a person (the ground station, Foxglove) watches the flight
as it happens. Pacing sleeps only; it never changes what the simulation computes, so a
paced run gives the same report as an unpaced one.

Simulated time 0 is ``origin_host_s`` on the host's monotonic clock: the CLI passes the
moment the command started, so the simulated clock reads the time since you pressed
enter, and the seconds spent importing and building the scene (the vehicle waits on its
pad then) are made up at full speed. Without an origin, the first update is the origin.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from sim.world import Scene

PACER_RATE_HZ = 100.0  # checks per simulated second (must divide the physics rate)


@dataclass
class RealTimePacer:
    """Sleeps so that simulated time advances ``rtf`` times as fast as host time."""

    rtf: float
    name: str = "pacer"
    rate_hz: float = PACER_RATE_HZ
    sleep: Callable[[float], None] = time.sleep
    host_clock: Callable[[], float] = time.monotonic
    origin_host_s: float | None = None  # host time of simulated time 0
    _origin: tuple[float, int] | None = field(default=None, init=False)
    slept_s: float = field(default=0.0, init=False)

    def __post_init__(self) -> None:
        if not self.rtf > 0:
            raise ValueError(f"rtf must be > 0, got {self.rtf}")

    def update(self, t_ns: int, scene: Scene) -> None:
        self.pace(t_ns)

    def pace(self, t_ns: int) -> None:
        """Sleep until host time has caught up with simulated time ``t_ns`` [ns]."""
        now = self.host_clock()
        if self._origin is None:
            if self.origin_host_s is None:
                self._origin = (now, t_ns)
                return
            self._origin = (self.origin_host_s, 0)
        host0, sim0 = self._origin
        ahead_s = (t_ns - sim0) / 1e9 / self.rtf - (now - host0)
        if ahead_s > 0:
            self.sleep(ahead_s)
            self.slept_s += ahead_s


__all__ = ["PACER_RATE_HZ", "RealTimePacer"]
