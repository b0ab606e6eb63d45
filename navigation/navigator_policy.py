"""The navigator's decisions (seed 003, sec. 3.3.2), as policies that tick (pure: numpy).

A policy is built for one goal. The node calls ``step(inputs)`` with where the vehicle is,
the time, whether the goal's cancel was asked, the markers seen and the answer to the
policy's last command; the policy answers with its next command (plan, sleep, send a reach
or a turn, poll or cancel it, publish progress) and, at the end, :class:`Finish`. The
outcomes, :class:`Sleep`, :class:`Log` and :class:`Finish` are the words every policy
shares (:mod:`flight_control.policy`); the plan and flight-goal commands and their answers
are the navigator's own. The node only carries commands out and converts messages
(:mod:`navigation.navigator_node`).

Following a path (:class:`NavigatePolicy`; every explore leg too): plan from where the
vehicle is to the goal (``plan_attempts`` tries, ``replan_period_s`` apart), then follow
the waypoints with reaches (the reach sphere shrunk at sharp corners so the flown chord
cuts a corner by at most ``corner_cut``: :mod:`navigation.following`). Before a leg that
turns by more than ``turn_first_angle`` it stops at the corner and turns to face the leg,
so the forward depth camera maps what is ahead; then it looks before it goes: it plans
again on a map that holds a depth cloud captured after the turn (the path's stamp is the
map's; it waits up to ``map_wait_s`` for one) and switches if the path changed. The camera
saw the obstacles beside the old leg only side-on, or not at all: a corner planned round as
unknown (free) space is often in the way once seen. Every ``replan_period_s`` it plans
again from here, and so it does before each leg after the first: the map has grown since
the path was planned. When the leg is no longer clear (the planner cannot go straight to
its end, or the end is no longer free: a plan to it ends at another cube) or the new
path's length differs from what is left of the current one by more than
``replan_tolerance`` (the live map changed the path's cost), it switches. Both checks are
needed: when a lane ends inside a block, the planner's snap can make the leg to the corner
beside the block look clear, and the last leg then flies into the face the camera mapped
seconds before.
When the leg is blocked and no new path is found (the goal may turn out to be inside a
block whose faces the camera had not seen), it stops, plans again ``plan_attempts`` times,
then gives up with no path. A failed reach is re-planned from where the vehicle is, up to
``max_reach_failures``.

Exploring (:class:`ExplorePolicy`): the predefined exploration path of the arena and start
pad (with loop closures) or, when there is none or the goal gives an area, boustrophedon
lanes spaced by the down camera's footprint (:func:`explore_waypoints`); each leg is
followed as above, a lane through points on it (:func:`lane_points`), passed without
stopping where the lane goes on their way and the map leaves room to stop past them
(``pass_stop_s``), so a detour round an obstacle comes back to the
lane (a point in an obstacle, or reached only by a detour longer than
``LANE_POINT_DETOUR_M``, is passed by after one plan); a waypoint with no path is skipped
or, with
``replace_blocked_lane_ends``, replaced by the nearest point toward its lane's other end
that has one. It stops as soon as a wanted marker is seen (the vehicle then holds where it
is) or the time budget is used up. While none is seen, it sweeps again, up to
``explore_sweeps`` times: lanes along the area's longer side, then across it, in turn
(after a predefined path, whose shape says nothing of how a robot it missed moves, the
lanes along come first: they have the fewest ends, so cover the area soonest). A robot
moves while the lanes are flown, and one sweep can miss it (a robot driving beside a lane
can stay out of the camera's footprint as the vehicle passes); lanes parallel to its track
cannot miss it, so the next sweep crosses the last one's lanes. A goal built with an
interrupted one's :class:`ExploreSoFar` (:meth:`ExplorePolicy.so_far`: its sweep, that
sweep's waypoints, the first one not reached, the coverage grid) for the same area,
altitude and markers goes on from there: the mission's HOLD cancels the goal (or the
fault makes flight control refuse a goal first: a flight error) and its RESUME sends a new
one, which would otherwise fly the lanes already flown again. The first
waypoint left is planned from where the vehicle is now; a lane left half-flown goes on
through its points beyond the vehicle.

Surveying (:class:`SurveyPolicy`): quarter turns after takeoff, so the depth camera maps
all around.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Generator, Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

from flight_control.frames import wrap_pi
from flight_control.policy import Finish, Log, Outcome, Sleep, expect
from navigation.astar import path_length
from navigation.coverage import CoverageGrid, coverage_lanes, footprint_half_size, lane_spacing
from navigation.following import corner_radius, turn_angle

FloatArray = npt.NDArray[np.float64]
POLL_S = 0.1  # s, how often a running goal looks at its flight-control action
LANE_STEP_M = 0.5  # m, an unreachable explore waypoint is tried this much nearer its lane
LANE_DETOUR = 1.2  # a replacement's path is at most this times the straight line (+ a step)
# m, a lane's point is flown to by a path at most this much longer than the straight line:
# round a block in the lane (the contest's 3 m wall across the lane at y = 9 m: 4.3 m more),
# not round the far end of a wall that runs across the lane's whole width (its far side is
# the other sweep's, whose lanes run along the wall)
LANE_POINT_DETOUR_M = 5.0
FACE_LEG_MIN_M = 0.3  # m, a waypoint nearer than this (horizontally) keeps the heading
END_TOLERANCE_M = 1e-6  # m, a plan to a leg's end that ends farther away snapped it: not free

#: How each policy can end (its subset of :class:`Outcome`); the node maps each to its
#: action's result code (:mod:`navigation.navigator_messages`).
NAVIGATE_OUTCOMES = frozenset({Outcome.SUCCEEDED, Outcome.NO_PATH, Outcome.FLIGHT_ERROR,
                               Outcome.CANCELED})
SURVEY_OUTCOMES = frozenset({Outcome.SUCCEEDED, Outcome.FLIGHT_ERROR, Outcome.CANCELED})
EXPLORE_OUTCOMES = frozenset({Outcome.MARKER_FOUND, Outcome.COVERED, Outcome.TIME_BUDGET,
                              Outcome.FLIGHT_ERROR, Outcome.CANCELED})
#: The explore ends a next goal goes on from (:meth:`ExplorePolicy.so_far`): the goal
#: canceled (the mission's HOLD) or a flight error (the fault that holds the mission can
#: make flight control refuse the next reach or turn before the cancel comes: a VIO drop,
#: "no valid position estimate"). The others end the exploration: nothing is left of it.
EXPLORE_INTERRUPTED = frozenset({Outcome.CANCELED, Outcome.FLIGHT_ERROR})


def _pick(cls: Any, params: object) -> Any:
    return cls(**{f.name: getattr(params, f.name) for f in dataclasses.fields(cls)})


@dataclass(frozen=True)
class FollowTuning:
    """How paths are followed (``config/navigator.yaml``; units and ranges in
    :class:`navigation.params.NavigatorParams`)."""

    plan_attempts: int
    replan_period_s: float  # s
    replan_tolerance: float  # m
    map_wait_s: float  # s
    turn_first_angle: float  # rad
    waypoint_radius: float  # m
    corner_cut: float  # m
    goal_radius: float  # m
    cruise_speed: float  # m/s
    max_reach_failures: int
    pass_stop_s: float  # s, a point passed at speed v is stopped within v * this past it

    @classmethod
    def of(cls, params: object) -> FollowTuning:
        """The fields of ``params`` (a :class:`~navigation.params.NavigatorParams`)."""
        return _pick(cls, params)


@dataclass(frozen=True)
class ExploreTuning:
    """How areas are explored (``config/navigator.yaml``)."""

    explore_sweeps: int
    replace_blocked_lane_ends: bool
    coverage_cell: float  # m
    down_camera_fovy_deg: float  # deg
    down_camera_aspect: float
    lane_overlap: float
    lane_point_spacing: float  # m
    wall_margin: float  # m
    arena: str
    start_pad: int

    @classmethod
    def of(cls, params: object) -> ExploreTuning:
        """The fields of ``params`` (a :class:`~navigation.params.NavigatorParams`)."""
        return _pick(cls, params)


# -- commands (policy -> node) -------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Plan:
    """Ask ``/navigation/plan_path`` from ``start`` to ``goal`` [m]; answer :class:`Planned`."""

    start: FloatArray
    goal: FloatArray


@dataclass(frozen=True, eq=False)
class SendReach:
    """Send a ``/flight_control/reach`` goal; answer :class:`Sent`."""

    target: FloatArray  # m
    yaw: float  # rad
    radius: float  # m
    speed: float  # m/s
    stop_at_target: bool


@dataclass(frozen=True)
class SendTurn:
    """Send a ``/flight_control/turn`` goal; answer :class:`Sent`."""

    yaw: float  # rad
    relative: bool = False


@dataclass(frozen=True)
class PollAction:
    """Whether the flight-control goal sent last has ended; answer :class:`ActionState`."""


@dataclass(frozen=True)
class CancelAction:
    """Cancel the flight-control goal sent last and wait for the cancel; no answer."""


@dataclass(frozen=True, eq=False)
class NavigateProgress:
    """Publish navigate feedback: the path, the waypoint flown to, the distance left [m]."""

    path: FloatArray
    waypoint: int
    distance_left: float


@dataclass(frozen=True, eq=False)
class ExploreProgress:
    """Publish explore feedback."""

    coverage: float  # 0..1
    markers_found: tuple[int, ...]
    waypoint: FloatArray  # the explore waypoint flown to [m]


@dataclass(frozen=True)
class ExploreFinish(Finish):
    """Explore's end: the :class:`Finish`, the share of the area seen (0..1) and the
    markers seen, by id."""

    coverage: float = 0.0
    markers_found: tuple[int, ...] = ()


@dataclass(frozen=True, eq=False)
class ExploreSoFar:
    """How far an exploration got: the goal it was for (``area``, ``altitude``,
    ``wanted``), the sweep being flown (0-based), that sweep's ``waypoints`` (N, 3) [m] and
    where they came from, ``next_leg``: the index of the first of them not yet reached,
    the waypoints flown and skipped so far, and the coverage grid's cells seen. The node
    keeps the one of an explore goal canceled (the mission's HOLD) and hands it to the
    next goal, which continues from there when it is for the same area, altitude and
    markers (:meth:`continues`); a restarted navigator has none and starts over."""

    area: FloatArray
    altitude: float  # m
    wanted: frozenset[int]
    sweep: int
    waypoints: FloatArray
    source: str
    next_leg: int
    flown: int
    skipped: int
    seen: npt.NDArray[np.bool_]

    def continues(self, area: FloatArray, altitude: float, wanted: frozenset[int]) -> bool:
        """Whether a goal for ``area``, ``altitude`` [m] and ``wanted`` is this one's."""
        return (self.area.shape == area.shape and bool(np.array_equal(self.area, area))
                and self.altitude == altitude and self.wanted == wanted)


Command = (Plan | Sleep | SendReach | SendTurn | PollAction | CancelAction | NavigateProgress
           | ExploreProgress | Log | Finish)


# -- answers (node -> policy) --------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Planned:
    """The planner's answer: the path (None: failed), its message, the stamp [ns] of the map
    it was planned on, and whether the failure is one that blocks a leg (the goal is in an
    obstacle or cut off from the start; not: the start is too close to an obstacle)."""

    path: FloatArray | None
    message: str
    stamp_ns: int = 0
    blocks_leg: bool = False


@dataclass(frozen=True)
class Sent:
    """Whether the flight-control goal was accepted; the rejection's message if not."""

    accepted: bool
    message: str = ""


@dataclass(frozen=True)
class ActionState:
    """The flight-control goal: still running (``done`` False) or its result."""

    done: bool
    success: bool = False
    message: str = ""


Answer = Planned | Sent | ActionState


@dataclass(frozen=True, eq=False)
class Inputs:
    """What the policy is told at one step: the time [ns], where the vehicle is [m, ENU],
    its heading [rad], whether the goal's cancel was asked, marker id -> last capture stamp
    [ns], and the answer to the last command (None for commands with no answer)."""

    now_ns: int
    position: FloatArray
    yaw: float = 0.0
    cancel_requested: bool = False
    markers: Mapping[int, int] = field(default_factory=dict)
    answer: Answer | None = None


T = TypeVar("T")
Script = Generator[Command, "Answer | None", T]


def explore_waypoints(tuning: ExploreTuning, explore_paths: Mapping[str, Mapping[int, Any]],
                      field_min: FloatArray, field_max: FloatArray, area: FloatArray,
                      altitude: float, here: FloatArray, sweep: int = 0
                      ) -> tuple[FloatArray, str]:
    """The explore path (N, 3) for an area ((M, 2) polygon; empty = the field [m] between
    ``field_min`` and ``field_max``) and where it came from. Sweep 0 is the predefined path
    (when the field has one); the lane sweeps are along the area's longer side, then across
    it (along its shorter side), in turn, each from the corner nearest ``here``. The lanes
    along come first because they are the fewest, so the quickest full cover; a predefined
    path, not being lanes, says nothing of which way a robot it missed moves."""
    t = tuning
    predefined = (explore_paths.get(t.arena, {}).get(t.start_pad) if len(area) == 0
                  else None)
    lane_sweep = sweep - (predefined is not None)
    across = lane_sweep % 2 == 1
    how = "coverage lanes across" if across else "coverage lanes over"
    spacing = lane_spacing(altitude, t.down_camera_fovy_deg, t.down_camera_aspect,
                           t.lane_overlap)
    start = here[:2]
    if len(area) == 0:
        if predefined is not None and lane_sweep < 0:
            xy, source = predefined, f"explore path of {t.arena} pad {t.start_pad}"
        else:
            lo = field_min[:2] + t.wall_margin
            hi = field_max[:2] - t.wall_margin
            xy = coverage_lanes(lo, hi, spacing, start, across=across)
            source = f"{how} the field"
    else:
        xy = coverage_lanes(area.min(axis=0), area.max(axis=0), spacing, start, across=across)
        source = f"{how} the area"
    return np.column_stack([xy, np.full(len(xy), altitude)]), source


def lane_points(start: FloatArray, end: FloatArray, spacing: float,
                past: FloatArray | None = None) -> FloatArray:
    """The points (N, 3) strictly between a lane's ``start`` and ``end``, evenly spaced at
    most ``spacing`` [m] apart (none on a lane that short); with ``past``, only those
    beyond it along the lane (the vehicle, when the lane's start was replaced by a point
    further on). The lane is flown through them so a detour round an obstacle in it comes
    back to the lane at the next one; planned end to end, the shortest path can leave the
    lane for good (a lane blocked at one end is then flown as a diagonal, which can pass
    metres from a robot driving along the lane)."""
    d = end - start
    n = math.ceil(float(np.linalg.norm(d)) / spacing - 1e-9)
    if n <= 1:
        return np.empty((0, 3))
    fractions = np.arange(1, n) / n
    if past is not None:
        fractions = fractions[fractions > float((past - start) @ d) / float(d @ d)]
    return start + np.outer(fractions, d)


def _xy(point: FloatArray) -> str:
    return f"({point[0]:.2f}, {point[1]:.2f})"


def _not_straight(path: FloatArray, end: FloatArray) -> bool:
    """Whether a planned ``path`` to ``end`` is not the straight line: a detour, or its end
    snapped to a cube beside ``end`` (which is then not free)."""
    return len(path) > 2 or not np.allclose(path[-1], end, rtol=0.0, atol=END_TOLERANCE_M)


@dataclass(frozen=True)
class _Flown:
    outcome: Outcome
    message: str


class _Policy:
    """A script (a generator of commands) fed one :class:`Inputs` per step."""

    def __init__(self) -> None:
        self.result: Finish | None = None
        self.why: str  # why the last flight-control goal did not succeed (set by _run)
        self._inputs: Inputs  # the last step's (set by step)
        self._script = self._main()

    def step(self, inputs: Inputs) -> Command:
        """The next command, given what the last one answered; :class:`Finish` at the end
        (and from then on)."""
        if self.result is not None:
            return self.result
        self._inputs = inputs
        try:
            return self._script.send(inputs.answer)  # the first answer is None: it starts
        except StopIteration as end:
            self.result = end.value
            return end.value

    def _main(self) -> Script[Finish]:
        raise NotImplementedError
        yield  # pragma: no cover

    # -- what the last step said ----------------------------------------------------------
    @property
    def _now(self) -> Inputs:
        return self._inputs

    @property
    def here(self) -> FloatArray:
        return self._now.position

    def _stop(self) -> bool:
        """The caller's stop condition (explore's marker or time budget): none here."""
        return False

    # -- sub-scripts ------------------------------------------------------------------------
    def _plan(self, start: FloatArray, goal: FloatArray) -> Script[Planned]:
        return expect((yield Plan(start, goal)), Planned)

    def _run(self, command: SendReach | SendTurn, stoppable: bool) -> Script[bool | None]:
        """Run a flight-control goal to its end: whether it succeeded (``self.why`` says
        why not); None when the goal's cancel was asked or, if ``stoppable``, the stop
        condition held (the flight goal is canceled)."""
        sent = expect((yield command), Sent)
        if not sent.accepted:
            self.why = f"rejected: {sent.message}"
            return False
        while True:
            state = expect((yield PollAction()), ActionState)
            if state.done:
                self.why = state.message
                return state.success
            if self._now.cancel_requested or (stoppable and self._stop()):
                yield CancelAction()
                self.why = "canceled" if self._now.cancel_requested else "stopped"
                return None
            yield Sleep(POLL_S)



class _Follower(_Policy):
    """A policy that follows planned paths (``follow``: how)."""

    def __init__(self, follow: FollowTuning) -> None:
        self.follow = follow
        super().__init__()

    def _hold(self) -> Script[None]:
        """Stop where the vehicle is (a reach to here)."""
        f = self.follow
        yield from self._run(SendReach(self.here, self._now.yaw, f.goal_radius, f.cruise_speed,
                                       True), False)

    def _progress(self, path: FloatArray, i: int) -> Command:
        return NavigateProgress(path, i, self._left(path, i))

    def _left(self, path: FloatArray, i: int) -> float:
        """What is left of ``path`` [m] from here, flying to waypoint ``i``."""
        return float(np.linalg.norm(path[i] - self.here)) + path_length(path[i:])

    def _fly(self, goal: FloatArray, *, radius: float, speed: float,
             then: FloatArray | None = None, attempts: int | None = None,
             max_detour: float = math.inf) -> Script[_Flown]:
        """Plan to ``goal`` and follow the path, re-planning as the module docstring says.
        ``then``: the way [m] the flight goes on from ``goal`` (None: it stops there); the
        goal is passed without stopping when the path's last leg turns into it by at most
        ``turn_first_angle`` and the map leaves room to stop past it
        (:meth:`_no_room_past`, asked again at each re-plan on the way). ``attempts``: plans
        tried before NO_PATH (None: ``plan_attempts``), also when the way turns out blocked;
        ``max_detour`` [m]: NO_PATH when a path (the first or a re-plan) is longer than the
        straight line by more."""
        f = self.follow
        attempts = f.plan_attempts if attempts is None else attempts
        path: FloatArray | None = None
        message = ""
        for attempt in range(attempts):
            planned = yield from self._plan(self.here, goal)
            path, message = planned.path, planned.message
            if path is not None:
                break
            if attempt + 1 < attempts:
                yield Sleep(f.replan_period_s)
        if path is None:
            return _Flown(Outcome.NO_PATH, message)

        def too_long(p: FloatArray) -> str | None:
            detour = path_length(p) - float(np.linalg.norm(goal - self.here))
            return f"a detour of {detour:.1f} m" if detour > max_detour else None

        if (why := too_long(path)) is not None:
            return _Flown(Outcome.NO_PATH, why)
        failures = 0
        i = 1
        fresh = True  # the path was just planned (else the map may have changed under it)
        while i < len(path):
            if not fresh:  # a new leg on a path planned legs ago: is it still clear?
                new, no_path = yield from self._recheck(path, i, goal, flying=False,
                                                        attempts=attempts)
                if no_path is not None:
                    return _Flown(Outcome.NO_PATH, no_path)
                fresh = True
                if new is not None:
                    if (why := too_long(new)) is not None:
                        return _Flown(Outcome.NO_PATH, why)
                    path, i = new, 1
                    continue  # (a new path of one point: the vehicle is at the goal)
            wp = path[i]
            last = i == len(path) - 1
            here, yaw = self.here, self._now.yaw
            heading = math.atan2(wp[1] - here[1], wp[0] - here[0])
            if float(np.hypot(*(wp[:2] - here[:2]))) < FACE_LEG_MIN_M:
                heading = yaw
            if abs(wrap_pi(heading - yaw)) > f.turn_first_angle:
                turned = yield from self._run(SendTurn(heading), True)
                if turned is None:
                    return _Flown(Outcome.CANCELED if self.why == "canceled"
                                  else Outcome.STOPPED, self.why)
                new, blocked = yield from self._look_again(path, i, goal)
                if new is None and blocked:
                    new, message = yield from self._plan_again(goal, attempts)
                    if new is None:
                        return _Flown(Outcome.NO_PATH, message)
                if new is not None:
                    if (why := too_long(new)) is not None:
                        return _Flown(Outcome.NO_PATH, why)
                    path, i = new, 1
                    continue
            # a sharp corner next: stop there (the vehicle turns in place before that leg);
            # at the goal, the way on from it (``then``) is the next leg, and the goal is
            # passed only with room to stop past it
            ahead = path if not last or then is None else np.vstack([path, wp + then])
            stop = (last and then is None) or turn_angle(ahead, i) > f.turn_first_angle
            passing_goal = last and not stop
            if passing_goal:
                stop = yield from self._no_room_past(path, i, speed)
            radius_i = radius if last else corner_radius(path, i, f.waypoint_radius,
                                                         f.corner_cut)
            sent = expect((yield SendReach(wp, heading, radius_i, speed, stop)), Sent)
            if not sent.accepted:
                return _Flown(Outcome.FLIGHT_ERROR, f"reach rejected: {sent.message}")
            period_ns = int(f.replan_period_s * 1e9)
            next_plan_ns = self._now.now_ns + period_ns
            switched = False
            while True:
                state = expect((yield PollAction()), ActionState)
                if state.done:
                    break
                if self._now.cancel_requested or self._stop():
                    yield CancelAction()
                    return _Flown(Outcome.CANCELED if self._now.cancel_requested
                                  else Outcome.STOPPED, "stopped on the way")
                yield self._progress(path, i)
                if self._now.now_ns >= next_plan_ns:
                    next_plan_ns = self._now.now_ns + period_ns
                    if passing_goal and not stop and (
                            yield from self._no_room_past(path, i, speed)):
                        # the map now shows something just past the goal: brake to it (a
                        # newer reach takes over at the vehicle's speed)
                        stop = True
                        sent = expect((yield SendReach(wp, heading, radius_i, speed, True)),
                                       Sent)
                        if not sent.accepted:
                            return _Flown(Outcome.FLIGHT_ERROR,
                                          f"reach rejected: {sent.message}")
                    new, no_path = yield from self._recheck(path, i, goal, flying=True,
                                                            attempts=attempts)
                    if no_path is not None:
                        return _Flown(Outcome.NO_PATH, no_path)
                    if new is not None:
                        if (why := too_long(new)) is not None:
                            return _Flown(Outcome.NO_PATH, why)  # its reach was canceled
                        path, i, switched = new, 1, True
                        break
                yield Sleep(POLL_S)
            if switched:
                continue
            if state.success:
                i, fresh = i + 1, False
                continue
            failures += 1
            if failures > f.max_reach_failures:
                return _Flown(Outcome.FLIGHT_ERROR, f"reach failed: {state.message}")
            planned = yield from self._plan(self.here, goal)
            if planned.path is None:
                return _Flown(Outcome.NO_PATH, planned.message)
            if (why := too_long(planned.path)) is not None:
                return _Flown(Outcome.NO_PATH, why)
            path, i = planned.path, 1
        return _Flown(Outcome.SUCCEEDED, "reached")

    def _no_room_past(self, path: FloatArray, i: int, speed: float) -> Script[bool]:
        """Whether the vehicle, passing waypoint ``i`` of ``path`` at ``speed``, has no
        room to stop past it: the straight line on from it, along the leg that arrives
        there, is not clear for ``speed * pass_stop_s``. A point passed at speed is
        stopped past, not at, when the next leg turns away (flight control then holds the
        point and the vehicle carries on along its way in): a point passed at 1 m/s half a
        metre before a wall across the lane would leave the vehicle's arms in the wall
        while it stops to turn round it."""
        arrival = path[i] - path[i - 1]
        length = float(np.linalg.norm(arrival))
        if length < END_TOLERANCE_M:
            return False
        room = speed * self.follow.pass_stop_s
        return (yield from self._straight_blocked(path[i], path[i] + arrival * (room / length)))

    def _straight_blocked(self, start: FloatArray, end: FloatArray) -> Script[bool]:
        """Whether the straight line from ``start`` to ``end`` is not clear on the map: the
        planner goes round (a path of more than two points) or says ``end`` is in an
        obstacle or cut off (it fails, or snaps ``end`` to a cube beside it)."""
        planned = yield from self._plan(start, end)
        return planned.path is None or _not_straight(planned.path, end)

    def _leg_blocked(self, path: FloatArray, i: int) -> Script[bool]:
        """Whether leg ``i`` of ``path`` is no longer clear from here: the planner cannot go
        straight to its end, or says the end is in an obstacle or cut off from here. Not
        when it cannot plan from here at all (the start too close to an obstacle: the
        vehicle is flying out of it), which says nothing of the leg."""
        planned = yield from self._plan(self.here, path[i])
        if planned.path is not None:
            return _not_straight(planned.path, path[i])
        return planned.blocks_leg

    def _recheck(self, path: FloatArray, i: int, goal: FloatArray, *, flying: bool,
                 attempts: int) -> Script[tuple[FloatArray | None, str | None]]:
        """Plan again from here to ``goal`` and judge leg ``i`` of ``path`` on the map as it
        is now: (the path to switch to or None, why there is no path or None). A blocked
        leg with no new path holds and plans again (:meth:`_plan_again`, ``attempts``
        times). ``flying``: the leg's reach is under way and is canceled before a switch or
        a hold."""
        planned = yield from self._plan(self.here, goal)
        new, blocked = yield from self._changed_path(path, i, planned.path)
        if flying and (new is not None or blocked):
            yield CancelAction()
        if new is None and blocked:
            new, message = yield from self._plan_again(goal, attempts)
            if new is None:
                return None, message
        return new, None

    def _changed_path(self, path: FloatArray, i: int, new: FloatArray | None
                      ) -> Script[tuple[FloatArray | None, bool]]:
        """(the path to switch to or None, whether leg ``i`` is blocked). ``new`` (a plan
        from here to the goal) is switched to when leg ``i`` of the current path is blocked
        or what is left of it differs from ``new`` in length by more than
        ``replan_tolerance``. A blocked leg with no new path is the caller's to stop on:
        keeping the old path would fly on into what the map now shows (an exploration goal
        can turn out to be inside a block, so that no re-plan succeeds)."""
        blocked = yield from self._leg_blocked(path, i)
        if new is None:
            return None, blocked
        if blocked or abs(path_length(new) - self._left(path, i)) > self.follow.replan_tolerance:
            return new, blocked
        return None, False

    def _look_again(self, path: FloatArray, i: int, goal: FloatArray
                    ) -> Script[tuple[FloatArray | None, bool]]:
        """After a turn: plan again on a map holding a depth cloud captured after it (up to
        ``map_wait_s``); :meth:`_changed_path`'s answer on that plan."""
        since_ns = self._now.now_ns
        deadline_ns = since_ns + int(self.follow.map_wait_s * 1e9)
        while True:
            planned = yield from self._plan(self.here, goal)
            if planned.stamp_ns >= since_ns or self._now.now_ns >= deadline_ns:
                break
            if self._now.cancel_requested or self._stop():
                return None, False
            yield Sleep(POLL_S)
        return (yield from self._changed_path(path, i, planned.path))

    def _plan_again(self, goal: FloatArray, attempts: int
                    ) -> Script[tuple[FloatArray | None, str]]:
        """The path ahead is blocked and the re-plan found none: hold here and try
        ``attempts`` times, ``replan_period_s`` apart (the map settles as the camera
        looks); (path or None, the last planner message)."""
        yield from self._hold()
        path: FloatArray | None = None
        message = ""
        for attempt in range(attempts):
            if self._now.cancel_requested or self._stop():
                break
            planned = yield from self._plan(self.here, goal)
            path, message = planned.path, planned.message
            if path is not None:
                break
            if attempt + 1 < attempts:
                yield Sleep(self.follow.replan_period_s)
        return path, f"the path ahead is blocked and no other path was found: {message}"


class NavigatePolicy(_Follower):
    """Fly to ``goal`` [m], then face ``yaw`` [rad] (NaN: any heading). Ends with one of
    :data:`NAVIGATE_OUTCOMES`: SUCCEEDED, NO_PATH, FLIGHT_ERROR or CANCELED."""

    def __init__(self, follow: FollowTuning, goal: FloatArray, *, radius: float,
                 speed: float, yaw: float = math.nan) -> None:
        self.goal = goal
        self.radius, self.speed, self.yaw = radius, speed, yaw
        super().__init__(follow)

    def _main(self) -> Script[Finish]:
        if not np.all(np.isfinite(self.goal)):
            return Finish(Outcome.NO_PATH, "goal is not finite")
        fly = yield from self._fly(self.goal, radius=self.radius, speed=self.speed)
        if fly.outcome is Outcome.SUCCEEDED and math.isfinite(self.yaw):
            ok = yield from self._run(SendTurn(self.yaw), False)
            if not ok:
                return Finish(Outcome.CANCELED if ok is None else Outcome.FLIGHT_ERROR,
                              f"final turn: {self.why}")
        return Finish(fly.outcome, fly.message)


class SurveyPolicy(_Policy):
    """``turns`` quarter turns to the left, where the vehicle is. Ends with one of
    :data:`SURVEY_OUTCOMES`: SUCCEEDED, FLIGHT_ERROR or CANCELED."""

    def __init__(self, turns: int) -> None:
        self.turns = turns
        super().__init__()

    def _main(self) -> Script[Finish]:
        for q in range(self.turns):
            ok = yield from self._run(SendTurn(math.pi / 2.0, relative=True), False)
            if not ok:
                return Finish(Outcome.CANCELED if ok is None else Outcome.FLIGHT_ERROR,
                              f"survey turn {q + 1}: {self.why}")
        return Finish(Outcome.SUCCEEDED, f"{self.turns} survey turns")


class ExplorePolicy(_Follower):
    """Explore ``area`` ((M, 2) polygon [m]; empty: the field) at ``altitude`` [m] until a
    marker of ``wanted`` is seen (none: one sweep), or ``budget_ns`` (0: none) has passed
    since ``start_ns``; ``explore_paths``: arena -> start pad -> (N, 2) waypoints. Ends
    (:class:`ExploreFinish`) with one of :data:`EXPLORE_OUTCOMES`: MARKER_FOUND, COVERED,
    TIME_BUDGET, FLIGHT_ERROR or CANCELED."""

    def __init__(self, follow: FollowTuning, explore: ExploreTuning, *, area: FloatArray,
                 altitude: float, field_min: FloatArray, field_max: FloatArray,
                 explore_paths: Mapping[str, Mapping[int, Any]], start_ns: int,
                 wanted: frozenset[int] = frozenset(), budget_ns: int = 0,
                 so_far: ExploreSoFar | None = None) -> None:
        self.explore = explore
        self.area, self.altitude = area, altitude
        self.field_min, self.field_max = field_min, field_max
        self.explore_paths = explore_paths
        self.start_ns, self.wanted, self.budget_ns = start_ns, wanted, budget_ns
        lo = self.area.min(axis=0) if len(self.area) else self.field_min[:2]
        hi = self.area.max(axis=0) if len(self.area) else self.field_max[:2]
        self.grid = CoverageGrid(lo, hi, explore.coverage_cell)
        self.half = footprint_half_size(altitude, explore.down_camera_fovy_deg,
                                        explore.down_camera_aspect)
        self.budget_used = False
        self._waypoint: FloatArray  # the explore waypoint flown to (set by _main)
        #: where an interrupted goal for the same area, altitude and markers got to: this
        #: one goes on from there (None: from the start)
        self.resumed = (so_far if so_far is not None
                        and so_far.continues(area, altitude, wanted)
                        and so_far.seen.shape == self.grid.seen.shape else None)
        self._ignored = so_far is not None and self.resumed is None
        if self.resumed is not None:
            self.grid.seen[...] = self.resumed.seen
        # the sweep flown, its waypoints and their source, the first waypoint not reached,
        # the waypoints flown and skipped (set by _main; read by so_far)
        self._sweep, self._leg, self._flown, self._skipped = 0, 0, 0, 0
        self._sweep_plan: tuple[FloatArray, str] | None = None
        super().__init__(follow)

    def so_far(self) -> ExploreSoFar | None:
        """How far this exploration got: what a next goal continues from when this one is
        interrupted. None before its first waypoint and once it ended other than
        interrupted (:data:`EXPLORE_INTERRUPTED`): a marker found, the area covered or the
        budget spent end the exploration."""
        if self._sweep_plan is None or (self.result is not None
                                        and self.result.outcome not in EXPLORE_INTERRUPTED):
            return None
        waypoints, source = self._sweep_plan
        return ExploreSoFar(self.area, self.altitude, self.wanted, self._sweep, waypoints,
                            source, self._leg, self._flown, self._skipped, self.grid.seen.copy())

    def seen(self) -> tuple[int, ...]:
        """The markers seen since the start, by id."""
        return tuple(sorted(i for i, t in self._now.markers.items() if t >= self.start_ns))

    def _stop(self) -> bool:
        """Mark what the down camera sees from here; whether a wanted marker is seen or the
        time budget is used up."""
        here, alt = self.here, self.altitude
        self.grid.mark(here[:2], (self.half[0] * here[2] / alt, self.half[1] * here[2] / alt)
                       if alt > 0 else self.half, self._now.yaw)
        if self.wanted & set(self.seen()):
            return True
        if self.budget_ns and self._now.now_ns - self.start_ns >= self.budget_ns:
            self.budget_used = True
            return True
        return False

    def _progress(self, path: FloatArray, i: int) -> Command:
        return ExploreProgress(self.grid.fraction, self.seen(), self._waypoint)

    def _waypoints(self, sweep: int) -> tuple[FloatArray, str]:
        return explore_waypoints(self.explore, self.explore_paths, self.field_min,
                                 self.field_max, self.area, self.altitude, self.here, sweep)

    def _main(self) -> Script[ExploreFinish]:
        f, e = self.follow, self.explore
        outcome: Finish | None = None
        stopped = False
        sweeps = e.explore_sweeps if self.wanted else 1
        so_far = self.resumed
        if self._ignored:
            yield Log("explore from the start: the goal interrupted last was for another "
                      "area, altitude or markers")
        if so_far is None:
            first_sweep, first_leg = 0, 0
            waypoints, source = self._waypoints(0)
        else:  # an interrupted goal's: its sweep from the first waypoint it did not reach
            first_sweep, first_leg = so_far.sweep, so_far.next_leg
            waypoints, source = so_far.waypoints, so_far.source
            self._flown, self._skipped = so_far.flown, so_far.skipped
        for sweep in range(first_sweep, sweeps):
            if sweep != first_sweep:
                waypoints, source = self._waypoints(sweep)
                first_leg = 0
            self._sweep, self._sweep_plan = sweep, (waypoints, source)
            yield Log(f"explore sweep {sweep + 1}/{sweeps}: {len(waypoints)} waypoints "
                      f"({source})" + (f", resumed at waypoint {first_leg + 1} after an "
                                       "interruption" if so_far is not None
                                       and sweep == first_sweep else ""))
            lanes = source.startswith("coverage lanes")
            for k in range(first_leg, len(waypoints)):
                wp = self._waypoint = waypoints[k]
                self._leg = k
                if self._stop():
                    stopped = True
                    break
                fly, at = _Flown(Outcome.SUCCEEDED, ""), f"waypoint {k + 1}"
                if lanes and k % 2 == 1:  # a lane: along it, through the points on it
                    start = waypoints[k - 1]
                    for point in lane_points(start, wp, e.lane_point_spacing, past=self.here):
                        fly = yield from self._fly(point, radius=f.waypoint_radius,
                                                   speed=f.cruise_speed, then=wp - start,
                                                   attempts=1, max_detour=LANE_POINT_DETOUR_M)
                        if fly.outcome not in (Outcome.SUCCEEDED, Outcome.NO_PATH):
                            at = f"the point {_xy(point)} m of the lane to waypoint {k + 1}"
                            break  # (a point in an obstacle, or far round one: the next)
                if fly.outcome in (Outcome.SUCCEEDED, Outcome.NO_PATH):
                    fly = yield from self._fly(wp, radius=f.waypoint_radius,
                                               speed=f.cruise_speed)
                if fly.outcome is Outcome.NO_PATH and e.replace_blocked_lane_ends:
                    # the lane's end is in an obstacle: fly the lane as far as it goes
                    partner = k ^ 1 if lanes else k - 1
                    nearer = ((yield from self._reachable_toward(wp, waypoints[partner]))
                              if 0 <= partner < len(waypoints) else None)
                    if nearer is not None:
                        fly = yield from self._fly(nearer, radius=f.waypoint_radius,
                                                   speed=f.cruise_speed)
                if fly.outcome is Outcome.NO_PATH:
                    self._skipped += 1
                    continue
                if fly.outcome is Outcome.CANCELED:
                    outcome = Finish(Outcome.CANCELED, "canceled")
                    break
                if fly.outcome is Outcome.FLIGHT_ERROR:
                    outcome = Finish(Outcome.FLIGHT_ERROR,
                                     f"sweep {sweep + 1}, {at}: {fly.message}")
                    break
                if fly.outcome is Outcome.STOPPED:
                    stopped = True
                    break
                self._flown += 1
            if stopped or outcome is not None or self._stop():
                break
        found = self.seen()
        flown, skipped = self._flown, self._skipped
        if outcome is None:
            hit = sorted(self.wanted & set(found))
            if hit:
                outcome = Finish(Outcome.MARKER_FOUND, f"marker {hit[0]} found ({source})")
                yield from self._hold()
            elif self.budget_used:
                outcome = Finish(Outcome.TIME_BUDGET, "time budget used up")
                yield from self._hold()
            else:
                outcome = Finish(Outcome.COVERED,
                                 f"{flown}/{flown + skipped} waypoints flown in {sweeps} "
                                 f"sweep{'s' * (sweeps > 1)} (last: {source}), {skipped} "
                                 "skipped without a path")
        return ExploreFinish(outcome.outcome, outcome.message, self.grid.fraction, found)

    def _reachable_toward(self, wp: FloatArray, partner: FloatArray
                          ) -> Script[FloatArray | None]:
        """The point nearest ``wp`` on the segment to ``partner`` (its lane's other end, or
        the path's previous waypoint), in ``LANE_STEP_M`` steps, that the planner reaches
        from here along the lane: by a path at most ``LANE_DETOUR`` times the straight
        line (plus one step), not round the far side of what blocks it. None when none is.
        A lane whose end is inside an obstacle is then still flown up to it: skipping the
        end would skip the whole lane (and a robot driving along it), and a reachable point
        behind the block would make the path cut across the field instead of along the
        lane."""
        length = float(np.linalg.norm(partner - wp))
        here = self.here
        for d in np.arange(LANE_STEP_M, length, LANE_STEP_M):
            point = wp + (partner - wp) * (d / length)
            planned = yield from self._plan(here, point)
            straight = float(np.linalg.norm(point - here))
            if planned.path is not None and (
                    path_length(planned.path) <= LANE_DETOUR * straight + LANE_STEP_M):
                return point
        return None


__all__ = [
    "EXPLORE_INTERRUPTED",
    "EXPLORE_OUTCOMES",
    "LANE_DETOUR",
    "LANE_POINT_DETOUR_M",
    "LANE_STEP_M",
    "NAVIGATE_OUTCOMES",
    "POLL_S",
    "SURVEY_OUTCOMES",
    "ActionState",
    "Answer",
    "CancelAction",
    "Command",
    "ExploreFinish",
    "ExplorePolicy",
    "ExploreProgress",
    "ExploreSoFar",
    "ExploreTuning",
    "FollowTuning",
    "Inputs",
    "NavigatePolicy",
    "NavigateProgress",
    "Plan",
    "Planned",
    "PollAction",
    "SendReach",
    "SendTurn",
    "Sent",
    "SurveyPolicy",
    "explore_waypoints",
    "lane_points",
]
