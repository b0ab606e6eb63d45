"""The mission's supervision logic: a ``transitions`` HierarchicalMachine over the tables.

:class:`Mission` is the model. Inputs are its methods, one per thing that can happen:
operator commands (:meth:`start`, :meth:`pause`, :meth:`resume`, :meth:`abort`,
:meth:`return_home`, :meth:`receive_sequence`) answer with a :class:`Reply`; action
results (:meth:`took_off`, :meth:`landed`, :meth:`marker_not_found`...) and alerts
(:meth:`error`) move the machine.
Outputs go to a :class:`MissionDriver`: entering a state starts its action
(:data:`ACTIONS`), leaving it cancels whatever is still running there (cancel reaches the
active child: a pause, an abort or an error in ``mission.pad.land`` cancels the
precision landing), and every change and event is reported. An input that does not
apply to the current state (a late action result) is ignored and returns False.

Errors go through :data:`~fsm.mission_table.ERROR_POLICY`: the cause picks the reaction,
the reaction is a trigger of the meta-machine. A transient cause (while resumes are left,
``MissionConfig.max_resumes``) first holds in ``held``; the driver, which has the clock,
then calls :meth:`Mission.recover` (the cause clear for its settle time: back to the
state held in, its action restarted), :meth:`Mission.give_up` (the deadline passed: the
permanent reaction) or :meth:`Mission.held_landed` (the FCU's failsafe landed the
vehicle). A reaction the current state cannot take is already covered by what it does
(battery low while returning home, anything while landing now) or, on the ground in
preflight, becomes a stop. The first error that stops
the mission is kept as :attr:`Mission.stop` (the report's reason).

Pure module: transitions and the standard library only.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from functools import partial
from typing import Any, Protocol

from transitions.extensions import HierarchicalMachine
from transitions.extensions.nesting import NestedState

from fsm.mission_table import (
    ERROR_POLICY,
    INITIAL,
    PAD_LANDINGS,
    RECOVERABLE,
    RESUMABLE,
    SEPARATOR,
    STATES,
    SUSPEND,
    TRANSITIONS,
    ErrorCause,
    Phase,
    Reaction,
    StateSpec,
    phase_of,
    terminal_states,
)

Vec2 = tuple[float, float]


class EventKind(Enum):
    """``MissionEvent.KIND_*``."""

    PHASE_CHANGED = 0
    COMMAND_ACCEPTED = 1
    COMMAND_REJECTED = 2
    ROBOT_FOUND = 3
    SEQUENCE_RECEIVED = 4
    PAD_REACHED = 5
    LANDED = 6
    LANDING_FAILED = 7
    MODULE_FAULT = 8
    BATTERY_LOW = 9
    ABORTED = 10  # the mission stopped (stopped or landed on an error)
    COMPLETED = 11
    PAD_SKIPPED = 12
    PICTURES_SENT = 13
    ERROR = 14  # any other error; cause and reaction in the values


class Severity(Enum):
    """``MissionEvent.SEVERITY_*``."""

    INFO = 0
    WARN = 1
    ERROR = 2


@dataclass(frozen=True)
class MissionEvent:
    kind: EventKind
    message: str
    severity: Severity = Severity.INFO
    marker_id: int = 0  # the robot or pad concerned, 0 = none
    values: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Reply:
    """The answer to an operator command."""

    accepted: bool
    reason: str = ""


@dataclass(frozen=True)
class Skip:
    """A pad of the sequence that was not landed on, and why."""

    pad: int
    reason: str


@dataclass(frozen=True)
class Stop:
    """The error that ended the mission early: its cause, the reaction and where it was."""

    cause: ErrorCause
    reaction: Reaction
    detail: str
    state: str

    def describe(self) -> str:
        return f"{self.cause.value} in {self.state}: {self.detail} ({self.reaction.name})"


@dataclass(frozen=True)
class MissionConfig:
    """What the mission knows before it starts: the target robot (a mission parameter),
    the start pad, and where every pad is (the field is known to all teams, seed 3.1)."""

    target_robot: int
    start_pad: int
    pads: Mapping[int, Vec2]  # pad id -> map-frame centre [m]
    search_radius_near: float = 0.5  # m, the first landing attempt looks this far
    search_radius_wide: float = 2.0  # m, the pad-search branch looks this far
    max_resumes: int = 0  # resumes after a transient error; 0: every error is permanent

    def __post_init__(self) -> None:
        if self.start_pad not in self.pads:
            raise ValueError(f"start pad {self.start_pad} is not among the pads "
                             f"{sorted(self.pads)}")
        if not 0.0 <= self.search_radius_near <= self.search_radius_wide:
            raise ValueError("search radii must satisfy 0 <= near <= wide, got "
                             f"{self.search_radius_near} and {self.search_radius_wide}")
        if self.max_resumes < 0:
            raise ValueError(f"max_resumes must be >= 0, got {self.max_resumes}")


class MissionDriver(Protocol):
    """What the machine asks of the world (the mission node implements it with actions).

    Each ``start`` request is answered later by one input of :class:`Mission`."""

    def check_health(self) -> None:
        """Ask every module for its health -> :meth:`Mission.preflight_result`."""

    def takeoff(self) -> None:
        """Arm and take off -> :meth:`Mission.took_off`."""

    def explore(self, target_robot: int) -> None:
        """Explore until ``target_robot`` is seen -> :meth:`Mission.robot_found`."""

    def send_pictures(self) -> None:
        """Hover, send the robot's pictures -> :meth:`Mission.pictures_sent`."""

    def navigate(self, target: Vec2) -> None:
        """Fly to above ``target`` -> :meth:`Mission.arrived` / :meth:`Mission.unreachable`."""

    def precision_land(self, pad: int, position: Vec2, search_radius: float) -> None:
        """-> :meth:`Mission.landed` / :meth:`Mission.marker_not_found`."""

    def land(self) -> None:
        """Land where the vehicle is -> :meth:`Mission.landed`."""

    def hold(self) -> None:
        """Stop moving and stay (pause, or a stop: the pilot takes over)."""

    def cancel(self) -> None:
        """Cancel the action still running, if any."""

    def state_changed(self, state: str) -> None:
        """The machine entered ``state`` (a nested name)."""

    def emit(self, event: MissionEvent) -> None:
        """Something the operator and the log should know."""


#: The action each state starts when entered (a :class:`Mission` method).
ACTIONS: dict[str, str] = {
    "preflight": "_do_preflight",
    "mission.takeoff": "_do_takeoff",
    "mission.explore": "_do_explore",
    "mission.report_robot": "_do_report_robot",
    "mission.await_sequence": "_do_await_sequence",
    "mission.pad.navigate": "_do_pad_navigate",
    "mission.pad.land": "_do_pad_land",
    "mission.pad.search": "_do_pad_search",
    "mission.pad.takeoff": "_do_takeoff",
    "paused": "_do_hold",
    "held": "_do_hold",
    "returning.navigate": "_do_return_navigate",
    "returning.land": "_do_return_land",
    "landing_now": "_do_land_now",
    "completed": "_do_completed",
    "stopped": "_do_stopped",
    "landed": "_do_landed",
}


class _State(NestedState):
    separator = SEPARATOR


class _Machine(HierarchicalMachine):
    state_cls = _State


def _states_with_callbacks(model: Mission, specs: Sequence[StateSpec],
                           prefix: str = "") -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for spec in specs:
        name = prefix + spec.name
        entry: dict[str, Any] = {"name": spec.name}
        if spec.children:
            entry["children"] = _states_with_callbacks(model, spec.children,
                                                       name + SEPARATOR)
            entry["initial"] = spec.initial
        enter = [] if spec.children else [model._changed]  # reported before its action
        if name in ACTIONS:
            enter.append(getattr(model, ACTIONS[name]))
            if not spec.terminal:
                entry["on_exit"] = [model._cancel_action]
        if enter:
            entry["on_enter"] = enter
        out.append(entry)
    return out


def _condition(model: Mission, name: str) -> Callable[[], bool]:
    method: Callable[[], bool] = getattr(model, name)
    return method


class _Core:
    """What transitions binds its triggers to and keeps ``state`` on; the inputs are
    :class:`Mission`'s methods, which fire the triggers after their own checks."""

    state: str


def build_machine(model: Mission) -> HierarchicalMachine:
    """The HierarchicalMachine of the tables; its callbacks are ``model``'s methods."""
    transitions: list[dict[str, Any]] = [
        {"trigger": t.trigger, "source": t.source, "dest": t.dest,
         "conditions": [_condition(model, c) for c in t.conditions],
         "unless": [_condition(model, c) for c in t.unless]}
        for t in TRANSITIONS]
    transitions += [{"trigger": "resume", "source": "paused", "dest": dest,
                     "conditions": [partial(model.paused_in, dest)]} for dest in RESUMABLE]
    transitions += [{"trigger": "resume", "source": "held", "dest": dest,
                     "conditions": [partial(model.paused_in, dest)]} for dest in RECOVERABLE]
    return _Machine(model=model.core, states=_states_with_callbacks(model, STATES),
                    transitions=transitions, initial=INITIAL, queued=True,
                    auto_transitions=False)


class Mission:
    """The mission model; see the module docstring. ``state`` is the nested state name."""

    def __init__(self, config: MissionConfig, driver: MissionDriver) -> None:
        self.config = config
        self.driver = driver
        self.sequence: tuple[int, ...] = ()
        self.points: dict[int, int] = {}  # pad -> points, as the operator read them
        self.pad_index = 0  # the pad of the sequence in hand
        self.score = 0
        self.landed_pads: list[int] = []
        self.skipped: list[Skip] = []
        self.robot_marker: int | None = None
        self.stop: Stop | None = None
        self.resume_to: str | None = None  # the state a pause or a hold resumes into
        #: the transient error the mission is held on (``held``), None otherwise
        self.held: Stop | None = None
        self.resumes = 0  # resumes after transient errors so far
        self._terminal = frozenset(terminal_states())
        self.core = _Core()
        self.machine = build_machine(self)

    @property
    def state(self) -> str:
        """The nested state name, ``mission.pad.land``."""
        return self.core.state

    # -- what the outside reads --------------------------------------------------------
    @property
    def phase(self) -> Phase:
        return phase_of(self.state)

    @property
    def finished(self) -> bool:
        return self.state in self._terminal

    @property
    def target_pad(self) -> int:
        """The pad being flown to or landed on, 0 when none."""
        if self.state in ("mission.pad.navigate", "mission.pad.land", "mission.pad.search"):
            return self.sequence[self.pad_index]
        return 0

    def triggers(self) -> list[str]:
        """The triggers the current state answers to."""
        return list(self.machine.get_triggers(self.state))

    # -- conditions ---------------------------------------------------------------------
    def has_more_pads(self) -> bool:
        return self.pad_index < len(self.sequence)

    def sequence_over(self) -> bool:
        return bool(self.sequence) and self.pad_index >= len(self.sequence)

    def paused_in(self, state: str) -> bool:
        """The state a pause or a hold resumes into is ``state``."""
        return self.resume_to == state

    @property
    def resumes_left(self) -> int:
        return max(0, self.config.max_resumes - self.resumes)

    # -- operator commands ---------------------------------------------------------------
    def start(self) -> Reply:
        if self.state != INITIAL:
            return self._reject("START", f"already started (state {self.state})")
        return self._accept("START", "start")

    def pause(self) -> Reply:
        if self.state not in RESUMABLE:
            return self._reject("PAUSE", f"nothing to pause in state {self.state}")
        self.resume_to = self.state
        return self._accept("PAUSE", "pause")

    def resume(self) -> Reply:
        if self.state != "paused":
            return self._reject("RESUME", f"not paused (state {self.state})")
        return self._accept("RESUME", "resume")

    def abort(self, reason: str = "") -> Reply:
        if self.finished or self.state == INITIAL:
            return self._reject("ABORT", f"nothing to abort in state {self.state}")
        self._emit(EventKind.COMMAND_ACCEPTED, f"ABORT accepted: {reason or 'no reason'}")
        self.error(ErrorCause.OPERATOR_ABORT, reason or "operator's ABORT")
        return Reply(True)

    def return_home(self, reason: str = "") -> Reply:
        if Reaction.RETURN_AND_LAND.value not in self.triggers():
            return self._reject("RETURN_HOME", f"cannot return home from state {self.state}")
        self._emit(EventKind.COMMAND_ACCEPTED, f"RETURN_HOME accepted: {reason or 'no reason'}")
        self.error(ErrorCause.OPERATOR_RETURN, reason or "operator's RETURN_HOME")
        return Reply(True)

    def receive_sequence(self, pads: Sequence[int], points: Sequence[int] = ()) -> Reply:
        """The operator's landing sequence, with the points each pad is worth (optional,
        for the score so far)."""
        if self.state != "mission.await_sequence":
            return self._reject("SEQUENCE", f"not waiting for a sequence (state {self.state})")
        problem = self._sequence_problem(pads, points)
        if problem:
            return self._reject("SEQUENCE", problem)
        self.sequence = tuple(int(p) for p in pads)
        self.points = dict(zip(self.sequence, (int(v) for v in points), strict=False))
        self.pad_index = 0
        self._emit(EventKind.SEQUENCE_RECEIVED,
                   f"landing sequence {list(self.sequence)}", values=(
                       ("pads", " ".join(map(str, self.sequence))),
                       ("points", " ".join(str(self.points.get(p, 0)) for p in self.sequence))))
        self._fire("sequence_received")
        return Reply(True)

    def _sequence_problem(self, pads: Sequence[int], points: Sequence[int]) -> str:
        if not pads:
            return "empty landing sequence"
        unknown = sorted(set(pads) - set(self.config.pads))
        if unknown:
            return f"unknown pads {unknown} (known: {sorted(self.config.pads)})"
        if len(set(pads)) != len(pads):
            return f"a pad appears twice in {list(pads)}"
        if points and len(points) != len(pads):
            return f"{len(points)} points for {len(pads)} pads"
        if any(v < 0 for v in points):
            return "negative points"
        return ""

    # -- results of the actions ----------------------------------------------------------
    def preflight_result(self, ok: bool, detail: str = "") -> bool:
        if self.state != "preflight":
            return False
        if ok:
            return self._fire("preflight_passed")
        return self.error(ErrorCause.PREFLIGHT_FAILED, detail)

    def took_off(self) -> bool:
        return self._fire("took_off")

    def robot_found(self, marker_id: int) -> bool:
        if self.state != "mission.explore" or marker_id != self.config.target_robot:
            return False
        self.robot_marker = marker_id
        self._emit(EventKind.ROBOT_FOUND, f"robot {marker_id} found", marker_id=marker_id)
        return self._fire("robot_found")

    def explore_ended(self, detail: str) -> bool:
        """Exploration is over and the target robot was not seen."""
        if self.state != "mission.explore":
            return False
        return self.error(ErrorCause.ROBOT_NOT_FOUND, detail)

    def pictures_sent(self) -> bool:
        if self.state != "mission.report_robot":
            return False
        self._emit(EventKind.PICTURES_SENT, "robot pictures sent to the operator",
                   marker_id=self.robot_marker or 0)
        return self._fire("pictures_sent")

    def arrived(self) -> bool:
        if self.state == "mission.pad.navigate":
            pad = self.target_pad
            self._emit(EventKind.PAD_REACHED, f"above pad {pad}", marker_id=pad)
        return self._fire("arrived")

    def unreachable(self, detail: str) -> bool:
        """Navigation found no path: a pad of the sequence is skipped, anything else fails."""
        if self.state == "mission.pad.navigate":
            return self._skip(f"no path: {detail}")
        return self.action_failed(f"navigate: {detail}")

    def landed(self, touchdown_error_m: float | None = None) -> bool:
        """Touchdown: on the pad in hand in ``mission.pad.*``, or at home/in place."""
        if self.state in ("mission.pad.land", "mission.pad.search"):
            pad = self.sequence[self.pad_index]
            self.landed_pads.append(pad)
            self.score += self.points.get(pad, 0)
            values = () if touchdown_error_m is None else (
                ("lateral_error_m", f"{touchdown_error_m:.3f}"),)
            self._emit(EventKind.LANDED, f"landed on pad {pad} (score {self.score})",
                       marker_id=pad, values=values)
            self.pad_index += 1
        return self._fire("landed")

    def marker_not_found(self, detail: str) -> bool:
        """The precision landing did not see the marker: search nearby, then skip."""
        if self.state == "mission.pad.land":
            pad = self.target_pad
            self._emit(EventKind.LANDING_FAILED, f"pad {pad} not seen at its known position "
                       f"({detail}): searching within {self.config.search_radius_wide:g} m",
                       Severity.WARN, marker_id=pad)
            return self._fire("marker_not_found")
        if self.state == "mission.pad.search":
            return self._skip(f"marker not seen within {self.config.search_radius_wide:g} m "
                              f"of its known position: {detail}")
        if self.state == "returning.land":
            return self._fire("marker_not_found")
        return False

    def action_failed(self, detail: str) -> bool:
        return self.error(ErrorCause.FLIGHT_ERROR, detail)

    def error(self, cause: ErrorCause, detail: str) -> bool:
        """Apply the error policy to ``cause``. False when it changes nothing.

        A transient cause with resumes left holds (``held``) in a state it can resume
        into; held or paused already, it changes nothing (the hold goes on, the operator
        holds). Otherwise, and for every other cause, the permanent reaction."""
        if self.finished or self.state == INITIAL:
            return False
        if ERROR_POLICY[cause].transient and self.resumes_left > 0:
            if self.state in ("held", "paused"):
                return False
            if self.state in RECOVERABLE:
                return self._suspend(cause, detail)
        reaction = ERROR_POLICY[cause].reaction
        if self.state == "preflight":
            reaction = Reaction.HOLD  # on the ground: nothing to fly or land
        if reaction.value not in self.triggers():
            return False  # already returning or landing
        self._emit_error(cause, detail, reaction.name)
        self.stop = Stop(cause, reaction, detail, self.state)  # the latest reaction counts
        return self._fire(reaction.value)

    def recover(self, detail: str) -> bool:
        """The held cause has cleared (for its settle time): back to the state held in,
        which restarts its action."""
        if self.state != "held" or self.held is None:
            return False
        held, self.held = self.held, None
        self.resumes += 1
        self._emit(EventKind.ERROR, f"{held.cause.value} cleared: {detail} -> RESUME "
                   f"{held.state} (resume {self.resumes} of {self.config.max_resumes})",
                   values=(("cause", held.cause.value), ("reaction", "RESUME"),
                           ("state", held.state)))
        return self._fire("resume")

    def give_up(self, detail: str) -> bool:
        """The held cause has not cleared by its deadline: its permanent reaction."""
        if self.state != "held" or self.held is None:
            return False
        held, self.held = self.held, None
        reaction = ERROR_POLICY[held.cause].reaction
        self._emit_error(held.cause, f"{held.detail}; {detail}", reaction.name)
        self.stop = Stop(held.cause, reaction, f"{held.detail}; {detail}", held.state)
        return self._fire(reaction.value)

    def take_off_again(self, detail: str) -> bool:
        """Held in a pad's landing (:data:`PAD_LANDINGS`), the vehicle has set down: its
        descent was under way when the cause came (or the FCU's failsafe set it down
        there). The resume takes off from where it stands and flies that pad again; the
        pad does not count as landed (the landing's end was not the precision landing's)."""
        if self.state != "held" or self.held is None or self.resume_to not in PAD_LANDINGS:
            return False
        pad = self.sequence[self.pad_index]
        self.resume_to = "mission.pad.takeoff"
        self._emit(EventKind.ERROR, f"set down on the way onto pad {pad} while held ({detail}):"
                   f" the resume takes off there and flies pad {pad} again", Severity.WARN,
                   marker_id=pad)
        return True

    def held_landed(self, detail: str) -> bool:
        """Held, the FCU's failsafe landed the vehicle: the mission ends there (no take-off
        again on its own from wherever that is)."""
        if self.state != "held" or self.held is None:
            return False
        held, self.held = self.held, None
        self.stop = Stop(held.cause, ERROR_POLICY[held.cause].reaction,
                         f"{held.detail}; {detail}", held.state)
        return self._fire("landed")

    def _suspend(self, cause: ErrorCause, detail: str) -> bool:
        self.resume_to = self.state
        self.held = Stop(cause, Reaction.HOLD, detail, self.state)
        self._emit_error(cause, detail, Reaction.HOLD.name,
                         then=f", then RESUME once clear ({self.resumes_left} left)")
        return self._fire(SUSPEND)

    def _emit_error(self, cause: ErrorCause, detail: str, reaction: str, then: str = "") -> None:
        kind = {ErrorCause.MODULE_SILENT: EventKind.MODULE_FAULT,
                ErrorCause.MODULE_ERROR: EventKind.MODULE_FAULT,
                ErrorCause.PREFLIGHT_FAILED: EventKind.MODULE_FAULT,
                ErrorCause.BATTERY_LOW: EventKind.BATTERY_LOW,
                ErrorCause.BATTERY_CRITICAL: EventKind.BATTERY_LOW}.get(cause, EventKind.ERROR)
        self._emit(kind, f"{cause.value}: {detail} -> {reaction}{then}", Severity.ERROR,
                   values=(("cause", cause.value), ("reaction", reaction),
                           ("state", self.state)))

    # -- machinery -----------------------------------------------------------------------
    def _fire(self, trigger: str) -> bool:
        if trigger not in self.triggers():
            return False
        return bool(self.machine.trigger_event(self.core, trigger))

    def _skip(self, reason: str) -> bool:
        pad = self.sequence[self.pad_index]
        self.skipped.append(Skip(pad, reason))
        self._emit(EventKind.PAD_SKIPPED, f"pad {pad} skipped: {reason}", Severity.WARN,
                   marker_id=pad)
        self.pad_index += 1
        return self._fire("skip")

    def _accept(self, command: str, trigger: str) -> Reply:
        self._emit(EventKind.COMMAND_ACCEPTED, f"{command} accepted")
        self._fire(trigger)
        return Reply(True)

    def _reject(self, command: str, reason: str) -> Reply:
        self._emit(EventKind.COMMAND_REJECTED, f"{command} rejected: {reason}", Severity.WARN)
        return Reply(False, reason)

    def _emit(self, kind: EventKind, message: str, severity: Severity = Severity.INFO,
              marker_id: int = 0, values: tuple[tuple[str, str], ...] = ()) -> None:
        self.driver.emit(MissionEvent(kind, message, severity, marker_id, values))

    def _changed(self) -> None:
        self.driver.state_changed(self.state)
        self._emit(EventKind.PHASE_CHANGED, self.state)

    def _cancel_action(self) -> None:
        self.driver.cancel()

    # -- what each state does when entered ------------------------------------------------
    def _pad_position(self, pad: int) -> Vec2:
        return self.config.pads[pad]

    def _do_preflight(self) -> None:
        self.driver.check_health()

    def _do_takeoff(self) -> None:
        self.driver.takeoff()

    def _do_explore(self) -> None:
        self.driver.explore(self.config.target_robot)

    def _do_report_robot(self) -> None:
        self.driver.send_pictures()

    def _do_await_sequence(self) -> None:
        self.driver.hold()

    def _do_pad_navigate(self) -> None:
        self.driver.navigate(self._pad_position(self.target_pad))

    def _do_pad_land(self) -> None:
        pad = self.target_pad
        self.driver.precision_land(pad, self._pad_position(pad), self.config.search_radius_near)

    def _do_pad_search(self) -> None:
        pad = self.target_pad
        self.driver.precision_land(pad, self._pad_position(pad), self.config.search_radius_wide)

    def _do_hold(self) -> None:
        self.driver.hold()

    def _do_return_navigate(self) -> None:
        self.driver.navigate(self._pad_position(self.config.start_pad))

    def _do_return_land(self) -> None:
        pad = self.config.start_pad
        self.driver.precision_land(pad, self._pad_position(pad), self.config.search_radius_wide)

    def _do_land_now(self) -> None:
        self.driver.land()

    def _do_completed(self) -> None:
        skipped = f", skipped {[s.pad for s in self.skipped]}" if self.skipped else ""
        self._emit(EventKind.COMPLETED, f"mission completed: landed on {self.landed_pads}"
                   f"{skipped}, score {self.score}")

    def _do_stopped(self) -> None:
        self.driver.hold()
        self._emit(EventKind.ABORTED, "mission stopped: "
                   + (self.stop.describe() if self.stop else "no reason"), Severity.ERROR)

    def _do_landed(self) -> None:
        self._emit(EventKind.ABORTED, "mission ended with an automatic landing: "
                   + (self.stop.describe() if self.stop else "no reason"), Severity.ERROR)


__all__ = ["ACTIONS", "EventKind", "Mission", "MissionConfig", "MissionDriver", "MissionEvent",
           "Reply", "Severity", "Skip", "Stop", "build_machine"]
