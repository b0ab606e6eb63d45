"""The words every policy and its node share (STYLE 16: policies tick, nodes wait). Pure:
the standard library only.

A policy is a pure object for one goal (or one node's decisions), fed one input at a time
with the node's time as int nanoseconds, and answering with typed commands the node
carries out. The policies that share this vocabulary:

- the flight behaviours (:mod:`flight_control.behaviours`): ``step(observation, now_ns)``
  at the setpoint rate, answering a ``Step`` whose ``outcome`` is None while they run;
- the navigator's (:mod:`navigation.navigator_policy`): a script fed ``Inputs`` that
  answers one command at a time, :class:`Sleep` and :class:`Log` among them, and ends
  with a :class:`Finish`;
- precision landing's (:mod:`navigation.precision_land_policy`): a method per event
  (frame, move ended, land ended, cancel), each answering a command or a :class:`Finish`;
- the mission's (:mod:`fsm.mission_driver`): ``step(input, now_ns)`` answering a list of
  commands; its waits are the :class:`Sleep` here tagged with the job they belong to, and
  it reads each action's end, which crosses a message, as an :class:`Outcome`;
- the ArUco scanner's (:mod:`perception.scan_policy`): queries at each image, with no
  goal and so no outcome, no wait and no log (its answers are values the node acts on);
  it shares the time convention only.

What is shared is how a goal ends (:class:`Outcome`, one set of words; each policy names
the subset it ends with, next to its code), the end itself (:class:`Finish`), waiting
(:class:`Sleep`), logging (:class:`Log`) and a node's wrong answer (:class:`PolicyError`,
:func:`expect`). What differs stays with each policy: the commands that act (a reach, a
plan, an action goal, a setpoint) and the answers they wait for, because each node carries
out different ones, and the mission tags its commands with a job so that a late answer is
dropped.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import TypeVar


class Outcome(Enum):
    """How a goal ended: the words of every policy, of the actions' results they become
    (each action's ``RESULT_*`` codes map onto these), and of the mission reading them."""

    SUCCEEDED = "succeeded"  # done as asked: reached, turned, landed, surveyed...
    LOST_CONTROL = "lost_control"  # the FCU left offboard, disarmed or went silent
    FCU_REJECTED = "fcu_rejected"  # the FCU refused a command the goal needed
    TIMEOUT = "timeout"  # not done in the goal's time
    CANCELED = "canceled"  # the goal's cancel was asked
    PREEMPTED = "preempted"  # a newer goal took over
    FLIGHT_ERROR = "flight_error"  # a flight-control goal it ran failed or was rejected
    FAILED = "failed"  # failed, as a reader that tells no more apart sees it (the mission)
    NO_PATH = "no_path"  # no path to the goal
    STOPPED = "stopped"  # the caller's stop condition held (explore: a marker, the budget)
    MARKER_FOUND = "marker_found"  # explore: stopped on a wanted marker
    COVERED = "covered"  # explore: the area covered without a wanted marker
    TIME_BUDGET = "time_budget"  # explore: the time budget used up
    MARKER_NOT_FOUND = "marker_not_found"  # the pad's marker never seen
    MARKER_LOST = "marker_lost"  # the pad's marker lost and not seen again


#: The outcomes that are a success (the action result's ``success``).
SUCCESSES = frozenset({Outcome.SUCCEEDED, Outcome.MARKER_FOUND, Outcome.COVERED})


@dataclass(frozen=True)
class Finish:
    """The goal's end: its outcome and a sentence for the result."""

    outcome: Outcome
    message: str

    @property
    def success(self) -> bool:
        """Whether the outcome is a success (:data:`SUCCESSES`)."""
        return self.outcome in SUCCESSES


@dataclass(frozen=True)
class Sleep:
    """Wait ``seconds`` on the node's clock."""

    seconds: float


@dataclass(frozen=True)
class Log:
    """Log a line; no answer."""

    text: str


class PolicyError(RuntimeError):
    """The node answered a command with the wrong kind of answer."""


A = TypeVar("A")


def expect(answer: object, kind: type[A]) -> A:
    """``answer`` if it is a ``kind``; else :class:`PolicyError` naming both."""
    if not isinstance(answer, kind):
        raise PolicyError(f"expected a {kind.__name__} answer, got {answer!r}")
    return answer


__all__ = ["SUCCESSES", "Finish", "Log", "Outcome", "PolicyError", "Sleep", "expect"]
