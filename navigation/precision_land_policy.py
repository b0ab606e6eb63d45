"""The precision-landing action's decisions around the seed's step, for one goal, one input
at a time. Pure: no runtime.

:class:`navigation.precision_landing.PrecisionLander` decides per marker frame (eq. 3, the
descent rules, the search, a lost marker, the phase timeouts). Around it the action goal
decides more, gathered here so a test can walk it without flying:

- whether a goal is accepted (:func:`goal_problem`): a finite pad position, within
  ``max_pad_distance`` of the vehicle, the vehicle high enough above it;
- which detection is the pad's (:func:`pad_marker`);
- the search spiral sized to the goal's ``search_radius`` (:func:`search_rings`), each
  of its legs checked against the map before it is flown (:class:`CheckLeg`: the node asks
  the path finder, with the navigator's clearance, and answers
  :meth:`~PrecisionLandPolicy.leg_planned`): a search point in an obstacle's clearance is
  skipped, a leg that is not clear is flown round along the planned path
  (:mod:`navigation.search_legs`);
- which pose goes with a frame: with CAPTURE the pose at the capture stamp for a frame
  showing the marker, else the latest (:meth:`PrecisionLandPolicy.needs_capture_pose`);
- the landing's timeout while no frames come at all (is the scanner running?);
- how a correction move ends: a reach that times out is no flight error (the next frame
  measures again from where the vehicle is), a failed or rejected one is;
- the outcome and its message (:data:`PRECISION_LAND_OUTCOMES`, :class:`Finish`: the
  words every policy shares, :mod:`flight_control.policy`).

The node feeds :class:`PrecisionLandPolicy`: :meth:`~PrecisionLandPolicy.poll` at each
poll (are frames waiting?), :meth:`~PrecisionLandPolicy.frame` per frame,
:meth:`~PrecisionLandPolicy.leg_planned` for a :class:`CheckLeg`,
:meth:`~PrecisionLandPolicy.reach_ended` or :meth:`~PrecisionLandPolicy.reach_rejected`
for a move, :meth:`~PrecisionLandPolicy.land_ended` for the final landing,
:meth:`~PrecisionLandPolicy.cancel`; and it carries out what each returns: :class:`Move`
(a reach, heading held), :class:`CheckLeg` (ask the path finder), :class:`Touchdown` (the
flight controller's landing), :class:`Finish` (the goal's result), or :class:`Wait`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

from flight_control.policy import Finish, Outcome
from navigation.precision_landing import (
    Fail,
    Failure,
    LandingParams,
    LandingStrategy,
    LandNow,
    Measurement,
    Phase,
    Pose,
    PrecisionLander,
    ReachTo,
    Wait,
)
from navigation.search_legs import CheckLeg, Leg, LegKind, PlanAnswer, judge_leg

TAKEOFF_MARGIN = 0.2  # m: a goal is refused below min_altitude minus this above the pad


#: How a goal can end; the node maps each to a PrecisionLand ``RESULT_*`` code (SUCCEEDED:
#: landed; FLIGHT_ERROR: a reach or the land failed, or was rejected).
PRECISION_LAND_OUTCOMES = frozenset({
    Outcome.SUCCEEDED, Outcome.MARKER_NOT_FOUND, Outcome.MARKER_LOST, Outcome.FLIGHT_ERROR,
    Outcome.TIMEOUT, Outcome.CANCELED})


_FAILURE_OUTCOME = {Failure.NOT_FOUND: Outcome.MARKER_NOT_FOUND,
                    Failure.LOST: Outcome.MARKER_LOST, Failure.TIMEOUT: Outcome.TIMEOUT}


@dataclass(frozen=True)
class Move:
    """Fly to ``position`` [m, map] and stop there, heading ``yaw`` [rad]."""

    position: tuple[float, float, float]
    yaw: float


@dataclass(frozen=True)
class Touchdown:
    """Hand the final landing to the flight controller."""


FrameCommand = Move | CheckLeg | Touchdown | Finish | Wait


def goal_problem(pad_id: int, pad_position: tuple[float, float, float],
                 vehicle: tuple[float, float, float], *, max_pad_distance: float,
                 min_altitude: float) -> str | None:
    """Why a goal for ``pad_id`` at ``pad_position`` [m] cannot start with the vehicle at
    ``vehicle`` [m], or None when it can. ``max_pad_distance`` [m] 0 means no limit."""
    if not all(math.isfinite(v) for v in pad_position):
        return f"pad_position {pad_position} is not finite"
    distance = math.hypot(pad_position[0] - vehicle[0], pad_position[1] - vehicle[1])
    if max_pad_distance > 0.0 and distance > max_pad_distance:
        return (f"pad {pad_id} is {distance:.2f} m away (more than {max_pad_distance:g} m): "
                "navigate there first")
    height = vehicle[2] - pad_position[2]
    if height < min_altitude - TAKEOFF_MARGIN:
        return (f"the vehicle is {height:.2f} m above the pad: take off first "
                f"(at least {min_altitude:g} m)")
    return None


def pad_marker(detections: Iterable[tuple[int, Measurement]], pad_id: int,
               ) -> Measurement | None:
    """The first detection carrying the pad's marker ID; None when none does. Lazy: an
    iterator is read no further than that detection."""
    for marker_id, measurement in detections:
        if marker_id == pad_id:
            return measurement
    return None


def search_rings(search_radius: float, spacing: float) -> int:
    """As many rings of the search spiral, ``spacing`` [m] apart, as cover
    ``search_radius`` [m] (at least one)."""
    return max(1, math.ceil(search_radius / spacing))


class PrecisionLandPolicy:
    """One precision-landing goal; see the module docstring. Times are int nanoseconds
    on the node's clock."""

    def __init__(self, params: LandingParams, strategy: LandingStrategy, pad_id: int,
                 pad_position: tuple[float, float, float], start: Pose, now_ns: int, *,
                 search_radius: float = 0.0) -> None:
        if search_radius > 0.0:
            params = replace(params, search_rings=search_rings(search_radius,
                                                               params.search_spacing))
        self.params = params
        self.pad_id = pad_id
        self.hold_yaw = start.yaw  # the heading every move keeps
        self.moving = False  # a Move was sent and has not ended
        self.last_leg: Leg | None = None  # the last search leg judged against the map
        self._leg_goal: tuple[float, float, float] | None = None  # search point being reached
        self._skips = 0  # search points skipped since the last move
        self.lander = PrecisionLander(params, pad_position, strategy, start_s=now_ns / 1e9)
        self.lander.start(start.position)

    # -- what the node reports -------------------------------------------------------------
    @property
    def phase(self) -> Phase:
        return self.lander.phase

    @property
    def reference_altitude(self) -> float:
        """m above the pad."""
        return self.lander.reference_altitude

    @property
    def leg_note(self) -> str:
        """What the last search leg check changed, for the log ("" when nothing)."""
        leg = self.last_leg
        if leg is None or leg.kind not in (LegKind.SKIP, LegKind.VIA):
            return ""
        return f"search point {leg.kind.value}: {leg.why}"

    @property
    def lateral_error(self) -> float:
        """m, the last (filtered, truncated) horizontal error; NaN before any."""
        error = self.lander.error
        return float(np.hypot(*error)) if error is not None else math.nan

    # -- inputs ----------------------------------------------------------------------------
    def poll(self, now_ns: int, frames_waiting: bool) -> Finish | None:
        """A poll: the landing's timeout ends it while no frames come at all."""
        if not frames_waiting and now_ns / 1e9 - self.lander.start_s > self.params.timeout_s:
            return Finish(Outcome.TIMEOUT, f"pad {self.pad_id}: no marker frames for "
                                           f"{self.params.timeout_s:g} s (is the scanner "
                                           "running?)")
        return None

    def needs_capture_pose(self, marker: Measurement | None) -> bool:
        """Whether ``marker`` goes with the pose at its capture stamp (CAPTURE, marker
        seen) rather than the latest; a frame whose capture pose is unknown is skipped."""
        return self.lander.capture and marker is not None

    def frame(self, now_ns: int, marker: Measurement | None, pose: Pose,
              position: tuple[float, float, float], speed: float,
              captured_ns: int | None = None) -> FrameCommand:
        """One frame the scanner looked at: ``marker`` the pad's (None: not in it),
        ``pose`` the vehicle's for it, ``position`` [m] and horizontal ``speed`` [m/s]
        the latest, ``captured_ns`` the image's exposure stamp (None: ``now_ns``)."""
        # a search leg flown round is one move for the lander, in several reaches
        command = self.lander.on_frame(now_ns / 1e9, marker, pose, position, speed,
                                       busy=self.moving or self._leg_goal is not None,
                                       captured_s=None if captured_ns is None
                                       else captured_ns / 1e9)
        if self.lander.phase is not Phase.SEARCH:
            self._leg_goal = None  # the marker is in view: the search is over
        elif self._leg_goal is not None and not self.moving and isinstance(command, Wait):
            return CheckLeg(position, self._leg_goal)  # on round: ask again from here
        return self._command(command, position)

    def _command(self, command: Fail | ReachTo | LandNow | Wait,
                 position: tuple[float, float, float]) -> FrameCommand:
        if isinstance(command, Fail):
            return Finish(_FAILURE_OUTCOME[command.failure],
                          f"pad {self.pad_id}: {command.failure.value}: {command.message}")
        if isinstance(command, ReachTo) and self.lander.phase is Phase.SEARCH:
            self._leg_goal = command.position  # a search leg: checked on the map first
            return CheckLeg(position, command.position)
        if isinstance(command, ReachTo):
            self.moving = True
            return Move(command.position, self.hold_yaw)
        if isinstance(command, LandNow):
            return Touchdown()
        return command

    def leg_planned(self, check: CheckLeg, answer: PlanAnswer,
                    path: np.ndarray | None = None, now_ns: int = 0) -> FrameCommand:
        """The path finder's ``answer`` (and ``path`` [m], (N, 3)) to ``check`` at
        ``now_ns``: the search leg flown straight or round (:class:`Move`), or its point
        skipped and the next one checked (:class:`CheckLeg`); :class:`Wait` when every
        point was skipped since the last move (the next frame tries again, the map may
        have changed), :class:`Finish` at the search's timeout."""
        leg = judge_leg(check.start, check.goal, answer, path,
                        max_detour=self.params.search_detour)
        self.last_leg = leg
        if leg.kind is LegKind.SKIP:
            self._leg_goal = None
            self._skips += 1
            rings = self.params.search_rings if self.lander.capture else 0
            if self._skips > 1 + 8 * rings:  # the whole spiral: none is clear from here
                return Wait("no search point is clear from here")
            return self._command(self.lander.skip_search_point(now_ns / 1e9), check.start)
        assert leg.target is not None
        self._skips = 0
        if leg.kind is not LegKind.VIA:
            self._leg_goal = None
        self.moving = True
        return Move(leg.target, self.hold_yaw)

    def reach_ended(self, success: bool, timed_out: bool, message: str,
                    now_ns: int | None = None) -> Finish | Wait:
        """The running move ended (at ``now_ns``: frames exposed before then do not count
        as fresh). A timeout (seen: stalled 3.0 cm from the target with a 3 cm radius) is
        no flight error: Wait says why, for the log."""
        self.moving = False
        if now_ns is not None:
            self.lander.move_ended(now_ns / 1e9)
        if success:
            return Wait()
        if timed_out:
            return Wait(f"correction move: {message}")
        return Finish(Outcome.FLIGHT_ERROR, f"reach failed: {message}")

    def reach_rejected(self, message: str) -> Finish | Wait:
        """Flight control refused the move's reach. A search leg's refused (its point
        outside the flyable volume, near a wall the map had not shown: random arena 209's
        pad in a corner) is skipped like a blocked one, the next frame going on with the
        search; any other move's refusal is a flight error."""
        self.moving = False
        if self.lander.phase is Phase.SEARCH:  # every move of the search is a search leg
            self._leg_goal = None
            return Wait(f"search point skipped: its reach was refused: {message}")
        return Finish(Outcome.FLIGHT_ERROR, f"reach rejected: {message}")

    def land_ended(self, success: bool, message: str) -> Finish:
        """The final landing ended (``success`` False also when it was rejected)."""
        if not success:
            return Finish(Outcome.FLIGHT_ERROR, f"land failed: {message}")
        return Finish(Outcome.SUCCEEDED, f"landed on pad {self.pad_id}")

    def cancel(self) -> Finish:
        return Finish(Outcome.CANCELED, "canceled")


__all__ = [
    "PRECISION_LAND_OUTCOMES",
    "TAKEOFF_MARGIN",
    "CheckLeg",
    "FrameCommand",
    "LegKind",
    "Move",
    "PlanAnswer",
    "PrecisionLandPolicy",
    "Touchdown",
    "goal_problem",
    "pad_marker",
    "search_rings",
]
