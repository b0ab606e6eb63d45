"""When a launch's process that died is started again: the respawn bookkeeping.

A launch file's node says ``respawn: true`` (and optionally ``respawn_delay``, seconds,
and ``respawn_max``, a count), as ROS 2 launch's ``respawn`` and ``respawn_delay``; every
node of a process group says the same or nothing. Under ``--transport ros2`` the
launcher (:mod:`runtime.processes.launcher`) asks a :class:`Respawns` what to do when a
process ends: a process that exits with code 0 has finished (a finishing node's process
after the mission) and is never started again; one that dies (a non-zero code or a
signal) is started again ``respawn_delay`` seconds later, at most ``respawn_max`` times
over the launch. ROS 2 launch has no limit; here a process that dies at once every time
ends the launch after its last allowed restart instead of looping forever. Pure module:
no processes are started here.
"""

from __future__ import annotations

import signal
from dataclasses import dataclass

__all__ = ["DEFAULT_RESPAWN_MAX", "Decision", "RespawnPolicy", "Respawns", "exit_text"]

DEFAULT_RESPAWN_MAX = 3
"""Restarts allowed per process over a launch when the launch file does not say."""


def exit_text(returncode: int) -> str:
    """How a process ended, from ``Popen.returncode``: ``exited with code 1``, ``killed by
    SIGKILL`` (a negative code is the signal's number)."""
    if returncode >= 0:
        return f"exited with code {returncode}"
    try:
        name = signal.Signals(-returncode).name
    except ValueError:
        name = f"signal {-returncode}"
    return f"killed by {name}"


@dataclass(frozen=True)
class RespawnPolicy:
    """Whether and when a process is started again: ``delay_s`` after its death [s of
    host time], at most ``max_count`` times over the launch."""

    delay_s: float = 0.0
    max_count: int = DEFAULT_RESPAWN_MAX

    def __post_init__(self) -> None:
        if not (0.0 <= self.delay_s <= 3600.0):
            raise ValueError(f"respawn_delay {self.delay_s!r}: expected 0 to 3600 s")
        if not (1 <= self.max_count <= 1000):
            raise ValueError(f"respawn_max {self.max_count!r}: expected 1 to 1000 restarts")


@dataclass(frozen=True)
class Decision:
    """What the launcher does about a process that ended: ``restart_at`` (host monotonic
    time [s]) when it is started again, None when its end ends the launch; ``line`` says
    so, naming the process, its pid and how it ended."""

    restart_at: float | None
    count: int  # the restart this is (1-based), or the restarts used when none is left
    line: str


class Respawns:
    """The launch's respawn bookkeeping: each respawning process's policy and the
    restarts it used."""

    def __init__(self, policies: dict[str, RespawnPolicy]) -> None:
        self.policies = dict(policies)
        self.used: dict[str, int] = dict.fromkeys(self.policies, 0)

    def ended(self, name: str, pid: int, returncode: int, now: float,
              why: str = "") -> Decision:
        """Process ``name`` (pid ``pid``) ended with ``returncode`` at ``now`` [s]:
        restart it later, or end the launch. ``why``: what killed it, when the launch
        did (``a node_stop fault``)."""
        how = exit_text(returncode) + (f" ({why})" if why else "")
        policy = self.policies.get(name)
        if returncode == 0:
            return Decision(None, self.used.get(name, 0),
                            f"{name} (pid {pid}) finished: {how}")
        if policy is None:
            return Decision(None, 0, f"{name} (pid {pid}) died: {how}")
        used = self.used[name]
        if used >= policy.max_count:
            return Decision(None, used, f"{name} (pid {pid}) died: {how}; not restarted: "
                                        f"its {policy.max_count} restarts are used")
        self.used[name] = used + 1
        return Decision(now + policy.delay_s, used + 1,
                        f"{name} (pid {pid}) died: {how}; restarting in "
                        f"{policy.delay_s:.1f} s ({used + 1} of {policy.max_count})")
