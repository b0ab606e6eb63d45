"""The mission node's policy: it drives :class:`~fsm.mission_machine.Mission` one input at a
time and answers with commands (STYLE 16: policies tick, nodes wait).

:class:`Driver` is the machine's :class:`~fsm.mission_machine.MissionDriver`. Each request
of the machine (the preflight check, take off, explore, send the pictures, navigate,
precision-land, land) opens a *job*: a command for the node to carry out and answer, the
answer tagged with the job:

- :class:`SendGoal` (an action goal) -> :class:`GoalDone` (the result read as an
  :class:`~flight_control.policy.Outcome`);
- :class:`CallArm` (the arm service, ``attempts`` times) -> :class:`ArmDone`;
- :class:`Probe` (which action servers are not ready) -> :class:`Probed`;
- :class:`Sleep` (the shared :class:`flight_control.policy.Sleep`, tagged with its job)
  -> :class:`Woke`.

The answer becomes the machine's input (``took_off``, ``robot_found``, ``unreachable``,
``marker_not_found``, ``action_failed``...) or the job's next command. A new request, or a
cancel (the machine left the state), ends the job in hand: a late answer is dropped, so a
result never reaches a state it does not belong to (:meth:`Driver.current` tells the node).

The other inputs: the operator's commands (:class:`OperatorCommand`,
:class:`UnknownCommand`), each answered on the events and followed by the state;
:class:`RobotSeen` (the target's pictures are kept, the latest ``max_pictures``, from the
start of the exploration to the end of the report: the exploration stops past the robot,
which may be out of view by then); :class:`VehicleStatus`, :class:`Position`,
:class:`Health`, and the watchdog's :class:`Tick`: in flight, the alerts (localisation
lost, the FCU link or its offboard control lost, module error or silent, battery low or
critical) go through the error policy (:data:`~fsm.mission_table.ERROR_POLICY`), and
``mission.await_sequence`` ends after ``sequence_timeout_s``.

Recovery: a transient cause holds the mission in ``held`` (the machine's). Each tick
there, the cause is clear when no alert is present and every module that was silent or in
error meanwhile (a respawned node) reports OK again, not merely reports; clear for
``recovery_settle_s``, the mission resumes where it was: the FCU out of offboard (its
failsafe flew), offboard is asked for first with a take-off goal that climbs where the
vehicle is (flight control's takeoff asks PX4 for offboard once the setpoints reach it),
then the state held in restarts its action from where the vehicle is (a new plan). Not clear after
``recovery_deadline_s``, the permanent reaction; the FCU's failsafe landed the vehicle
meanwhile (but for a take-off state, which begins on the ground), the mission ends in
``landed``. The time held is not the interrupted state's: the explore budget and the
sequence timeout count only the time spent in the state (``held_s`` adds the holds).

The report of the robot: hover ``report_hover_s``, then wait up to ``picture_timeout_s``
more for a first picture, then :class:`SendPictures` (without any, a :class:`NoPicture`:
the robot's ID and the vehicle's position, with a warning). Other outputs:
:class:`PublishEvent`, :class:`StateChanged`, :class:`PublishState` (a :class:`Snapshot`
taken when it happened) and :class:`CancelGoal`. ``timeline`` and ``events`` keep what
happened, with the companion time, for reports.

Pure module: the standard library, the mission machine and the policy vocabulary
(:mod:`flight_control.policy`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from functools import partial
from typing import Any, TypeVar

import flight_control.policy as policy
from flight_control.policy import Outcome
from fsm.mission_machine import (
    EventKind,
    Mission,
    MissionConfig,
    MissionEvent,
    Severity,
    Vec2,
)
from fsm.mission_table import PRECISION_LANDINGS, TAKEOFFS, ErrorCause, Phase, phase_of

Vec3 = tuple[float, float, float]
PROBE_PERIOD_S = 0.1  # preflight: the modules are asked again this often
PICTURE_POLL_S = 0.1  # after the hover: a first picture is looked for this often
#: the causes whose module may have died with a flight-control goal running (:meth:`Driver.hold`)
MODULE_CAUSES = frozenset({ErrorCause.MODULE_SILENT, ErrorCause.MODULE_ERROR})


@dataclass(frozen=True)
class DriverParams:
    """What the driver reads of the mission node's parameters (units and ranges:
    :class:`fsm.params.MissionParams`)."""

    cruise_altitude: float
    explore_altitude: float
    explore_budget_s: float
    health_topics: tuple[str, ...]
    preflight_timeout_s: float
    silence_timeout_s: float
    sequence_timeout_s: float
    report_hover_s: float
    picture_timeout_s: float
    max_pictures: int
    battery_low_warning: int
    battery_critical_warning: int
    land_speed: float
    arm_attempts: int
    failure_cause_wait_s: float
    status_timeout_s: float
    recovery_settle_s: float
    recovery_deadline_s: float


class Action(Enum):
    """The actions the mission sends goals to (the names of ``action_servers``)."""

    SURVEY_TAKEOFF = "survey_takeoff"  # from the start pad: climb, then turn round (mapping)
    TAKEOFF = "takeoff"
    LAND = "land"
    REACH = "reach"
    EXPLORE = "explore"
    NAVIGATE = "navigate"
    PRECISION_LAND = "precision_land"


class Order(Enum):
    """The operator's commands (``MissionCommand.COMMAND_*``)."""

    START = "start"
    PAUSE = "pause"
    RESUME = "resume"
    ABORT = "abort"
    RETURN_HOME = "return_home"
    SEQUENCE = "sequence"


# -- goals ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class TakeoffGoal:
    altitude: float  # m above the take-off point


@dataclass(frozen=True)
class ReachGoal:
    position: Vec3  # m, map frame; stop there


@dataclass(frozen=True)
class ExploreGoal:
    altitude: float  # m
    stop_marker_ids: tuple[int, ...]
    time_budget_s: float  # 0 = no limit


@dataclass(frozen=True)
class NavigateGoal:
    position: Vec3  # m, map frame; keep the heading


@dataclass(frozen=True)
class PrecisionLandGoal:
    pad: int
    position: Vec2  # m, map frame: where the pad should be
    search_radius: float  # m


@dataclass(frozen=True)
class LandGoal:
    speed: float  # m/s, 0 = the layer's default
    disarm: bool


Goal = TakeoffGoal | ReachGoal | ExploreGoal | NavigateGoal | PrecisionLandGoal | LandGoal


# -- inputs --------------------------------------------------------------------------------
@dataclass(frozen=True)
class OperatorCommand:
    order: Order
    reason: str = ""
    pads: tuple[int, ...] = ()  # SEQUENCE: the pads, in order
    points: tuple[int, ...] = ()  # SEQUENCE: what each is worth (optional)


@dataclass(frozen=True)
class UnknownCommand:
    code: int


@dataclass(frozen=True, eq=False)
class RobotSeen:
    marker_id: int
    picture: object  # the node's message, sent on as it is


@dataclass(frozen=True)
class VehicleStatus:
    position_valid: bool
    armed: bool
    landed: bool
    battery_warning: int  # px4 BatteryStatus.WARNING_*
    battery_remaining: float  # 0..1, NaN when unknown
    failsafe: bool = False  # the FCU's own failsafe action is active (it flies, not us)
    offboard: bool = False  # the FCU is in offboard mode (our setpoints fly the vehicle)
    offboard_signal_lost: bool = False  # the FCU misses our setpoint stream (COM_OF_LOSS_T)


@dataclass(frozen=True)
class Position:
    position: Vec3  # m, map frame


@dataclass(frozen=True)
class Health:
    topic: str
    ok: bool  # LEVEL_OK
    error: bool  # LEVEL_ERROR or worse
    message: str


@dataclass(frozen=True)
class Tick:
    """The watchdog's: check the alerts and the sequence timeout."""


@dataclass(frozen=True)
class Probed:
    job: int
    servers_down: tuple[str, ...]  # the action servers not ready


@dataclass(frozen=True)
class Woke:
    job: int


@dataclass(frozen=True)
class ArmDone:
    job: int
    refusal: str | None  # None: armed


@dataclass(frozen=True)
class GoalDone:
    """A goal's end, as the mission reads it (:func:`goal_outcome`): SUCCEEDED (explore:
    stopped on the target robot, its one stop marker), explore's COVERED or TIME_BUDGET
    (the robot not seen), NO_PATH (navigate), MARKER_NOT_FOUND or MARKER_LOST (precision
    land), else FAILED, a rejected goal included."""

    job: int
    outcome: Outcome
    message: str
    lateral_error: float = math.nan  # m, precision land's touchdown error


Reply = Probed | Woke | ArmDone | GoalDone
Input = (OperatorCommand | UnknownCommand | RobotSeen | VehicleStatus | Position | Health | Tick
         | Reply)


# -- commands ------------------------------------------------------------------------------
@dataclass(frozen=True)
class SendGoal:
    job: int
    action: Action
    goal: Goal


@dataclass(frozen=True)
class CallArm:
    job: int
    attempts: int


@dataclass(frozen=True)
class Probe:
    job: int


@dataclass(frozen=True)
class Sleep(policy.Sleep):
    """Wait ``seconds``; answer :class:`Woke`, tagged with the job."""

    job: int = field(kw_only=True)


Job = SendGoal | CallArm | Probe | Sleep
JOBS = (SendGoal, CallArm, Probe, Sleep)
#: The answer each job command waits for.
ANSWER: dict[type, type] = {SendGoal: GoalDone, CallArm: ArmDone, Probe: Probed, Sleep: Woke}


@dataclass(frozen=True)
class CancelGoal:
    """Cancel the goal still running, if any."""


@dataclass(frozen=True)
class PublishEvent:
    event: MissionEvent
    state: str  # the state it happened in


@dataclass(frozen=True)
class StateChanged:
    state: str


@dataclass(frozen=True)
class Snapshot:
    """What ``/mission/state`` says, at one time."""

    state: str
    phase: Phase
    previous_phase: Phase
    robot_marker_id: int  # 0 = not found yet
    landing_sequence: tuple[int, ...]
    pads_landed: tuple[int, ...]
    target_pad_id: int  # 0 = none
    pads_skipped: tuple[int, ...]
    score: int
    stop_reason: str
    phase_start_ns: int
    elapsed_ns: int | None  # since START; None before


@dataclass(frozen=True)
class PublishState:
    snapshot: Snapshot


@dataclass(frozen=True)
class NoPicture:
    """Stands for the robot when perception sent no picture: its ID, where we are."""

    marker_id: int
    x: float
    y: float


@dataclass(frozen=True, eq=False)
class SendPictures:
    pictures: tuple[object, ...]  # RobotSeen.picture, or one NoPicture


Command = Job | CancelGoal | PublishEvent | StateChanged | PublishState | SendPictures

R = TypeVar("R", Probed, Woke, ArmDone, GoalDone)


@dataclass
class _Module:
    """The latest health report of one module."""

    ok: bool = False
    error: bool = False
    message: str = ""
    last_ns: int | None = None  # None: never reported


class Driver:
    """See the module docstring. ``now_ns``: the companion time of the construction."""

    def __init__(self, config: MissionConfig, params: DriverParams, now_ns: int) -> None:
        self.params = params
        self.now_ns = now_ns
        self.mission = Mission(config, self)
        self.timeline: list[tuple[float, str]] = [(self.now_ns / 1e9, self.mission.state)]
        self.events: list[tuple[float, MissionEvent]] = []
        self.pictures: list[object] = []  # of the target robot, while collecting
        self.status: VehicleStatus | None = None
        self._status_ns: int | None = None  # when the latest status came
        self.position: Vec3 | None = None
        self.modules = {topic: _Module() for topic in params.health_topics}
        self.job = 0  # the job in hand; every request and cancel opens a new one
        #: the job's command waiting for its answer, and where the answer goes
        self._asked: tuple[Job, Callable[[Any], None]] | None = None
        self._waited: float  # s, the job's polling so far (set when it starts)
        self._collecting = False
        self._started_ns: int | None = None
        self._entered_ns = 0
        self._phase = self._previous_phase = phase_of(self.mission.state)
        self._out: list[Command]  # the commands of the step under way (set by step)
        #: an action that failed: the mission's stop reason if no cause comes, whether the
        #: FCU's failsafe was flying, and until when a cause may come (:meth:`_action_failed`)
        self._failure: tuple[str, bool, int] | None = None
        #: recovery: the time the interrupted state had run before its holds [s] (its
        #: budget counts only that), the time held in all [s], since when the held cause
        #: has been clear, and whether offboard is being asked for again
        self._used_s = 0.0
        self.held_s = 0.0
        self._clear_ns: int | None = None
        self._reengaging = False
        #: the modules silent or in error during this hold: each must report OK to resume
        self._returning: set[str] = set()

    def step(self, event: Input, now_ns: int) -> list[Command]:
        """Take one input at ``now_ns`` (int nanoseconds, companion clock); the commands
        it leads to, in order."""
        self.now_ns, self._out = now_ns, []
        if isinstance(event, Probed | Woke | ArmDone | GoalDone):
            self._answer(event)
        elif isinstance(event, OperatorCommand | UnknownCommand):
            self._command(event)
        elif isinstance(event, RobotSeen):
            if self._collecting and event.marker_id == self.mission.config.target_robot:
                self.pictures.append(event.picture)
                del self.pictures[:-self.params.max_pictures]
        elif isinstance(event, VehicleStatus):
            self.status, self._status_ns = event, now_ns
        elif isinstance(event, Position):
            self.position = event.position
        elif isinstance(event, Health):
            module = self.modules[event.topic]
            module.ok, module.error, module.message = event.ok, event.error, event.message
            module.last_ns = now_ns
        else:
            self._watchdog()
        return self._out

    def current(self, job: int) -> bool:
        """Whether ``job`` is still the one in hand (else its answer will be dropped)."""
        return job == self.job

    def snapshot(self, now_ns: int) -> Snapshot:
        m = self.mission
        return Snapshot(
            state=m.state, phase=self._phase, previous_phase=self._previous_phase,
            robot_marker_id=m.robot_marker or 0, landing_sequence=m.sequence,
            pads_landed=tuple(m.landed_pads), target_pad_id=m.target_pad,
            pads_skipped=tuple(s.pad for s in m.skipped), score=m.score,
            stop_reason=m.stop.describe() if m.stop else "", phase_start_ns=self._entered_ns,
            elapsed_ns=None if self._started_ns is None else now_ns - self._started_ns)

    def alerts(self) -> list[tuple[ErrorCause, str]]:
        """The error causes present now, the gravest first."""
        out: list[tuple[ErrorCause, str]] = []
        s, p = self.status, self.params
        if s is not None and not s.position_valid:
            out.append((ErrorCause.LOCALISATION_LOST,
                        "the FCU's position estimate is not valid (visual odometry lost)"))
        if s is not None and s.armed and not s.landed:  # in the air: offboard is ours
            assert self._status_ns is not None
            status_age = (self.now_ns - self._status_ns) / 1e9
            if status_age > p.status_timeout_s:
                out.append((ErrorCause.OFFBOARD_LOST,
                            f"FCU link lost: no /fcu/status for {status_age:.1f} s"))
            elif s.offboard_signal_lost:
                out.append((ErrorCause.OFFBOARD_LOST, "the FCU misses the offboard setpoints"))
        for topic, module in self.modules.items():
            age = self._age_s(module)
            if age is None or age > p.silence_timeout_s:
                out.append((ErrorCause.MODULE_SILENT, f"{topic}: no report for "
                            f"{'ever' if age is None else f'{age:.1f} s'}"))
            elif module.error:
                out.append((ErrorCause.MODULE_ERROR, f"{topic}: {module.message}"))
        if s is not None and s.battery_warning >= p.battery_critical_warning:
            out.append((ErrorCause.BATTERY_CRITICAL,
                        f"battery critical ({_percent(s.battery_remaining)})"))
        elif s is not None and s.battery_warning >= p.battery_low_warning:
            out.append((ErrorCause.BATTERY_LOW, f"battery low ({_percent(s.battery_remaining)})"))
        return out

    def _age_s(self, module: _Module) -> float | None:
        """Since the module's latest report [s]; None: it never reported."""
        return None if module.last_ns is None else (self.now_ns - module.last_ns) / 1e9

    def _down(self, module: _Module) -> bool:
        """The module is silent or reports an error (an alert of :meth:`alerts`)."""
        age = self._age_s(module)
        return age is None or age > self.params.silence_timeout_s or module.error

    # -- inputs ----------------------------------------------------------------------------
    def _answer(self, reply: Reply) -> None:
        if self._asked is None:
            return
        command, then = self._asked
        if reply.job == self.job and isinstance(reply, ANSWER[type(command)]):
            self._asked = None
            then(reply)

    def _command(self, c: OperatorCommand | UnknownCommand) -> None:
        m = self.mission
        if isinstance(c, UnknownCommand):
            self.emit(MissionEvent(EventKind.COMMAND_REJECTED, f"unknown command {c.code}",
                                   Severity.WARN))
        elif c.order is Order.START:
            if m.start().accepted:
                self._started_ns = self.now_ns
        elif c.order is Order.PAUSE:
            m.pause()
        elif c.order is Order.RESUME:
            m.resume()
        elif c.order is Order.ABORT:
            m.abort(c.reason)
        elif c.order is Order.RETURN_HOME:
            m.return_home(c.reason or "operator's RETURN_HOME")
        else:
            m.receive_sequence(c.pads, c.points)
        self._out.append(PublishState(self.snapshot(self.now_ns)))

    def _apply_alerts(self) -> None:
        """The error policy on every alert present now (not in preflight: on the ground
        before it, or over, the machine ignores them)."""
        if self.mission.state != "preflight":
            for cause, detail in self.alerts():
                self.mission.error(cause, detail)

    def _watchdog(self) -> None:
        m = self.mission
        self._apply_alerts()
        if self._failure is not None:  # (a cause that came meanwhile changed the state)
            detail, failsafe, deadline_ns = self._failure
            if self.now_ns >= deadline_ns:
                self._failure = None
                # the FCU's failsafe may have been reported during the wait (flight control
                # sees the FCU first) with no cause of its own: still its offboard loss
                if failsafe or (self.status is not None and self.status.failsafe):
                    m.error(ErrorCause.OFFBOARD_LOST,
                            f"{detail} (the FCU's failsafe active, no other cause reported "
                            f"in {self.params.failure_cause_wait_s:g} s)")
                else:
                    m.action_failed(detail)
        if m.state == "mission.await_sequence":
            waited = self._used_s + (self.now_ns - self._entered_ns) / 1e9
            if waited > self.params.sequence_timeout_s:
                m.error(ErrorCause.SEQUENCE_TIMEOUT, f"no landing sequence after {waited:.0f} s")
        elif m.state == "held":
            self._held()

    def _held(self) -> None:
        """Held on a transient cause: resume once clear for the settle time, else the
        permanent reaction at the deadline (see the module docstring)."""
        m, p, s, now = self.mission, self.params, self.status, self.now_ns
        if s is not None and s.landed and m.resume_to not in TAKEOFFS \
                and not m.take_off_again("the vehicle landed while held"):
            m.held_landed("the FCU's failsafe landed the vehicle while held")
            return
        held_s = (now - self._entered_ns) / 1e9
        # a module silent or in error while held (a respawned process) must come back OK,
        # not merely reporting: a restarted node says it has rebuilt its state that way
        self._returning |= {t for t, module in self.modules.items() if self._down(module)}
        if self.alerts() or any(not self.modules[t].ok for t in self._returning):
            self._clear_ns = None
        elif self._clear_ns is None:
            self._clear_ns = now
        clear_s = 0.0 if self._clear_ns is None else (now - self._clear_ns) / 1e9
        if self._clear_ns is not None and clear_s >= p.recovery_settle_s \
                and not self._reengaging:
            self._resume(held_s)
        elif held_s >= p.recovery_deadline_s:  # offboard being asked for included
            waiting = "; ".join(f"{t} back but not OK: {self.modules[t].message}"
                                for t in sorted(self._returning) if not self._down(
                                    self.modules[t]) and not self.modules[t].ok)
            m.give_up(f"not clear after {held_s:.1f} s (deadline {p.recovery_deadline_s:g} s)"
                      + (f" ({waiting})" if waiting and not self.alerts() else ""))

    def _resume(self, held_s: float) -> None:
        s = self.status
        if s is not None and s.armed and not s.landed and (
                not s.offboard or self.mission.resume_to in PRECISION_LANDINGS):
            # the FCU's failsafe flies: ask for offboard again (flight control's take-off
            # streams, asks PX4 for offboard and climbs where the vehicle is); a precision
            # landing held in its descent starts again from cruise altitude the same way
            self._reengaging = True
            self._ask(SendGoal(self._new_job(), Action.TAKEOFF,
                               TakeoffGoal(self.params.cruise_altitude)), self._reengaged)
            return
        self.mission.recover(f"clear for {self.params.recovery_settle_s:g} s, held "
                             f"{held_s:.1f} s")

    def _reengaged(self, reply: GoalDone) -> None:
        self._reengaging = False
        held_s = (self.now_ns - self._entered_ns) / 1e9
        if reply.outcome is Outcome.SUCCEEDED:
            self.mission.recover(f"clear for {self.params.recovery_settle_s:g} s, offboard "
                                 f"taken back, held {held_s:.1f} s")
            return
        self._clear_ns = None  # try again after another settle time, until the deadline
        self.emit(MissionEvent(EventKind.ERROR, f"offboard not taken back: {reply.message}",
                               Severity.WARN))

    # -- the machine's requests (MissionDriver) ----------------------------------------------
    def check_health(self) -> None:
        self._waited = 0.0
        self._ask(Probe(self._new_job()), self._probed)

    def takeoff(self) -> None:
        self._new_job()
        s, altitude = self.status, self.params.cruise_altitude
        if s is not None and s.armed and not s.landed and self.position is not None:
            # resumed in the air: flight control's take-off climbs where we are (and asks
            # for offboard when the FCU is not in it); the navigator's survey needs the ground
            self._ask(SendGoal(self.job, Action.TAKEOFF, TakeoffGoal(altitude)),
                      self._took_off)
        elif s is not None and s.armed:
            self._send_takeoff()
        else:
            self._ask(CallArm(self.job, self.params.arm_attempts), self._armed)

    def explore(self, target_robot: int) -> None:
        self.pictures.clear()
        self._collecting = True
        budget = self.params.explore_budget_s
        if budget > 0.0:  # resumed: what is left of it (the time held is not exploring)
            budget -= self._used_s
            if budget <= 0.0:
                self._new_job()
                self.mission.explore_ended(f"robot {target_robot} not seen: explore budget "
                                           f"{self.params.explore_budget_s:g} s spent")
                return
        goal = ExploreGoal(self.params.explore_altitude, (target_robot,), budget)
        self._ask(SendGoal(self._new_job(), Action.EXPLORE, goal),
                  partial(self._explored, target_robot))

    def send_pictures(self) -> None:
        self._collecting = True
        self._waited = 0.0
        self._ask(Sleep(self.params.report_hover_s, job=self._new_job()), self._hovered)

    def navigate(self, target: Vec2) -> None:
        goal = NavigateGoal((target[0], target[1], self.params.cruise_altitude))
        self._ask(SendGoal(self._new_job(), Action.NAVIGATE, goal), self._navigated)

    def precision_land(self, pad: int, position: Vec2, search_radius: float) -> None:
        self._ask(SendGoal(self._new_job(), Action.PRECISION_LAND,
                           PrecisionLandGoal(pad, position, search_radius)),
                  partial(self._precision_landed, pad))

    def land(self) -> None:
        self._ask(SendGoal(self._new_job(), Action.LAND, LandGoal(self.params.land_speed, True)),
                  self._landed)

    def hold(self) -> None:
        """Nothing more to send: with its goal canceled the layer below holds the last
        setpoint (the seed's stop leaves the vehicle as it is for the pilot). But held or
        stopped on a module silent or in error: its process may have died with a
        flight-control goal of its own running (the navigator's reach to the end of a leg,
        precision landing's descent), which no cancel reaches any more and which would fly
        on to its end; a reach to where the vehicle is takes the setpoint from it (flight
        control preempts the older goal), in the air, in offboard (the FCU's failsafe flies
        otherwise). Its answer is not waited for (a dead flight control gives none)."""
        m, s = self.mission, self.status
        why = m.held if m.state == "held" else m.stop if m.state == "stopped" else None
        if why is None or why.cause not in MODULE_CAUSES or self.position is None \
                or s is None or not (s.armed and not s.landed and s.offboard):
            return
        self._ask(SendGoal(self._new_job(), Action.REACH, ReachGoal(self.position)),
                  _ignore)

    def cancel(self) -> None:
        self._new_job()  # the one in hand is over
        self._out.append(CancelGoal())

    def state_changed(self, state: str) -> None:
        left, ran_s = self.timeline[-1][1], (self.now_ns - self._entered_ns) / 1e9
        if left == "held":
            self.held_s += ran_s
        if state in ("held", "paused"):  # the interrupted state's time so far
            self._used_s += ran_s
            self._clear_ns, self._reengaging, self._returning = None, False, set()
        elif not (left in ("held", "paused") and state == self.mission.resume_to):
            self._used_s = 0.0  # a new state, not one resumed
        self._failure = None  # a failure waiting for its cause belonged to the state left
        self._entered_ns = self.now_ns
        self.timeline.append((self.now_ns / 1e9, state))
        if phase_of(state) != self._phase:
            self._previous_phase, self._phase = self._phase, phase_of(state)
        self._out += [StateChanged(state), PublishState(self.snapshot(self.now_ns))]

    def emit(self, event: MissionEvent) -> None:
        self.events.append((self.now_ns / 1e9, event))
        self._out.append(PublishEvent(event, self.mission.state))

    # -- the jobs' answers ---------------------------------------------------------------------
    def _new_job(self) -> int:
        self.job += 1
        return self.job

    def _ask(self, command: Job, then: Callable[[R], None]) -> None:
        self._asked = (command, then)
        self._out.append(command)

    def _probed(self, reply: Probed) -> None:
        missing = [f"{name} server not available" for name in reply.servers_down]
        for topic, module in self.modules.items():
            if module.last_ns is None:
                missing.append(f"{topic} did not answer")
            elif not module.ok:
                missing.append(f"{topic} not OK: {module.message}")
        if self.status is None:
            missing.append("/fcu/status did not answer")
        elif not self.status.position_valid:
            missing.append("no valid position estimate")
        timeout = self.params.preflight_timeout_s
        if missing and self._waited < timeout:
            self._ask(Sleep(PROBE_PERIOD_S, job=self.job), self._probe_again)
        else:
            self.mission.preflight_result(not missing,
                                          f"after {timeout:g} s: " + "; ".join(missing))

    def _probe_again(self, _: Woke) -> None:
        self._waited += PROBE_PERIOD_S
        self._ask(Probe(self.job), self._probed)

    def _armed(self, reply: ArmDone) -> None:
        if reply.refusal is not None:
            self._action_failed(f"arm: {reply.refusal}")
        else:
            self._send_takeoff()

    def _send_takeoff(self) -> None:
        # from the start pad the navigator's take-off also maps all around; from a
        # sequence pad the flight-control take-off is enough
        first = self.mission.state == "mission.takeoff"
        action = Action.SURVEY_TAKEOFF if first else Action.TAKEOFF
        self._ask(SendGoal(self.job, action, TakeoffGoal(self.params.cruise_altitude)),
                  self._took_off)

    def _took_off(self, reply: GoalDone) -> None:
        if reply.outcome is Outcome.SUCCEEDED:
            self.mission.took_off()
        else:
            self._action_failed(f"takeoff: {reply.message}")

    def _explored(self, target_robot: int, reply: GoalDone) -> None:
        if reply.outcome is Outcome.MARKER_FOUND:
            self.mission.robot_found(target_robot)
        elif reply.outcome in (Outcome.COVERED, Outcome.TIME_BUDGET):
            self.mission.explore_ended(f"robot {target_robot} not seen: {reply.message}")
        else:
            self._action_failed(f"explore: {reply.message}")

    def _hovered(self, _: Woke) -> None:
        self._look_for_pictures()

    def _polled(self, _: Woke) -> None:
        self._waited += PICTURE_POLL_S
        self._look_for_pictures()

    def _look_for_pictures(self) -> None:
        if not self.pictures and self._waited < self.params.picture_timeout_s:
            self._ask(Sleep(PICTURE_POLL_S, job=self.job), self._polled)
            return
        self._collecting = False
        if not self.pictures:  # the operator still needs to know which robot it is
            target = self.mission.config.target_robot
            self.emit(MissionEvent(
                EventKind.ERROR, f"no picture of robot {target} from perception after "
                f"{self.params.report_hover_s + self._waited:.0f} s: its ID and our position "
                "sent", Severity.WARN, marker_id=target))
            x, y = self.position[:2] if self.position is not None else (math.nan, math.nan)
            self.pictures.append(NoPicture(target, x, y))
        self._out.append(SendPictures(tuple(self.pictures)))
        self.mission.pictures_sent()

    def _navigated(self, reply: GoalDone) -> None:
        if reply.outcome is Outcome.SUCCEEDED:
            self.mission.arrived()
        elif reply.outcome is Outcome.NO_PATH:
            self.mission.unreachable(reply.message)
        else:
            self._action_failed(f"navigate: {reply.message}")

    def _precision_landed(self, pad: int, reply: GoalDone) -> None:
        if reply.outcome is Outcome.SUCCEEDED:
            self.mission.landed(reply.lateral_error)
        elif reply.outcome in (Outcome.MARKER_NOT_FOUND, Outcome.MARKER_LOST):
            self.mission.marker_not_found(reply.message)
        else:
            self._action_failed(f"precision land on pad {pad}: {reply.message}")

    def _landed(self, reply: GoalDone) -> None:
        if reply.outcome is Outcome.SUCCEEDED:
            self.mission.landed()
        else:
            self._action_failed(f"land: {reply.message}")

    def _action_failed(self, detail: str) -> None:
        """An action failed. It may be the consequence of a cause the mission has not seen
        yet: the FCU's own failsafe flies the vehicle (it left offboard on a low battery, a
        lost link...), or flight control refused a goal for a fault that holds the mission
        (the position estimate invalid, the FCU link silent: flight control sees the FCU
        before the mission's /fcu/status does). A cause present now decides by the error
        policy at once; else the first to come within ``failure_cause_wait_s`` does (the
        battery's warning comes at 1 Hz, after the mode change). With none: under the
        FCU's failsafe it took the vehicle for a reason of its own (its offboard-loss
        failsafe: the link or the setpoint stream lost), ``offboard_lost``, a transient
        cause; otherwise the action itself failed, ``flight_error``. On the ground with
        no failsafe (an arm refused), the failure is its own cause at once. The wait is
        said as a warning event. It catches a lost estimate or the FCU's failsafe, which
        /fcu/status reports at 5 Hz, and the link lost if ``status_timeout_s`` ends within
        it; a silent module (``silence_timeout_s``, 3 s) comes too late for it."""
        s = self.status
        failsafe = s is not None and s.failsafe
        if not failsafe and (s is None or not s.armed or s.landed):
            self.mission.action_failed(detail)
            return
        state_then = self.mission.state
        self._apply_alerts()  # a cause already known decides at once
        if self.mission.state == state_then:
            wait_s = self.params.failure_cause_wait_s
            self.emit(MissionEvent(EventKind.ERROR, f"{detail}: waiting up to {wait_s:g} s "
                                   "for its cause", Severity.WARN))
            self._failure = (detail, failsafe, self.now_ns + round(wait_s * 1e9))


def _ignore(_: GoalDone) -> None:
    """A job whose answer changes nothing (the reach that holds)."""


def _percent(fraction: float) -> str:
    return "unknown" if math.isnan(fraction) else f"{100.0 * fraction:.0f} %"


def goal_outcome(action: Action, *, accepted: bool, success: bool, code: int,
                 codes: Mapping[int, Outcome]) -> Outcome:
    """What a finished goal means to the mission. A rejected goal failed, whatever its
    result's code says (a rejected goal's result is the default one, code 0, which for
    explore would read "area covered"); a success is a success, but for explore, whose
    codes say whether the robot was found; any other code by ``codes`` (the action's
    result codes that are not a plain failure), else a failure."""
    if not accepted:
        return Outcome.FAILED
    if success and action is not Action.EXPLORE:
        return Outcome.SUCCEEDED
    return codes.get(code, Outcome.FAILED)


__all__ = [
    "ANSWER", "JOBS", "Action", "ArmDone", "CallArm", "CancelGoal", "Command", "Driver",
    "DriverParams", "ExploreGoal", "Goal", "GoalDone", "Health", "Input", "Job", "LandGoal",
    "NavigateGoal", "NoPicture", "OperatorCommand", "Order", "Position", "PrecisionLandGoal",
    "Probe", "Probed", "PublishEvent", "PublishState", "ReachGoal", "Reply", "RobotSeen",
    "SendGoal", "SendPictures", "Sleep", "Snapshot", "StateChanged", "TakeoffGoal", "Tick",
    "UnknownCommand", "VehicleStatus", "Woke", "goal_outcome",
]
