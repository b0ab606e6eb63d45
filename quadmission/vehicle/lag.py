"""How far a paced simulation falls behind the wall clock, and how often.

:class:`LagMonitor` is fed the lag at each pacing step (host seconds the simulated world
is behind where ``rtf`` x the elapsed host time puts it; negative or zero when it keeps
up) and answers with a line to log when the world falls behind by more than
``threshold_s``, every ``repeat_s`` of host time while it stays behind, and when it has
caught up. Its :meth:`summary` holds the figures a report keeps. Pure: no clock of its
own, no printing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["LagMonitor"]


@dataclass
class LagMonitor:
    """Episodes of falling behind: when, how far, how long (see the module docstring)."""

    threshold_s: float = 0.05
    """Behind by more than this is behind [s of host time]."""
    repeat_s: float = 10.0
    """While behind, a line at most this often [s of host time]."""
    episodes: int = field(default=0, init=False)
    """Times the world fell behind by more than the threshold."""
    max_lag_s: float = field(default=0.0, init=False)
    """The largest lag seen [s]."""
    behind_s: float = field(default=0.0, init=False)
    """Host time spent behind [s]."""
    longest_s: float = field(default=0.0, init=False)
    """The longest episode [s of host time]."""
    _since: float | None = field(default=None, init=False)  # host time the episode began
    _said: float = field(default=0.0, init=False)  # host time of its last line
    _episode_max: float = field(default=0.0, init=False)
    _last: float | None = field(default=None, init=False)  # host time of the last update

    def __post_init__(self) -> None:
        if not 0.0 < self.threshold_s < 60.0:
            raise ValueError(f"threshold_s {self.threshold_s:g} s: expected 0 < s < 60")
        if not self.repeat_s > 0.0:
            raise ValueError(f"repeat_s {self.repeat_s:g} s: expected > 0")

    def update(self, host_s: float, lag_s: float) -> str | None:
        """The lag ``lag_s`` [s] at host time ``host_s`` [s]; a line to log, or None."""
        if self._since is not None and self._last is not None:
            self.behind_s += host_s - self._last
        self._last = host_s
        self.max_lag_s = max(self.max_lag_s, lag_s)
        if self._since is None:
            if lag_s <= self.threshold_s:
                return None
            self.episodes += 1
            self._since = self._said = host_s
            self._episode_max = lag_s
            return (f"falling behind real time: {lag_s * 1e3:.0f} ms behind "
                    f"(episode {self.episodes})")
        self._episode_max = max(self._episode_max, lag_s)
        if lag_s <= self.threshold_s / 2:  # caught up (with a margin: no flicker)
            took = host_s - self._since
            self.longest_s = max(self.longest_s, took)
            self._since = None
            return (f"caught up with real time after {took:.1f} s behind (at most "
                    f"{self._episode_max * 1e3:.0f} ms)")
        if host_s - self._said >= self.repeat_s:
            self._said = host_s
            return (f"still behind real time: {lag_s * 1e3:.0f} ms behind for "
                    f"{host_s - self._since:.1f} s (at most {self._episode_max * 1e3:.0f} ms)")
        return None

    def summary(self, host_s: float) -> dict[str, Any]:
        """The figures at host time ``host_s``: an episode still open counts to then."""
        longest = self.longest_s
        if self._since is not None:
            longest = max(longest, host_s - self._since)
        return {"threshold_s": self.threshold_s, "episodes": self.episodes,
                "max_lag_s": round(max(self.max_lag_s, 0.0), 4),
                "behind_s": round(self.behind_s, 3), "longest_s": round(longest, 3),
                "behind_at_end": self._since is not None}
