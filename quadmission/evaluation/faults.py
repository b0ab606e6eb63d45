"""Each fault kind's expected reaction, written once, and a run's faults judged by it.

The mission's reactions are not restated: a kind the mission must notice names the
:class:`~fsm.mission_table.ErrorCause` it shows as, and the reaction is that cause's in
:data:`~fsm.mission_table.ERROR_POLICY`. A lost link is the FCU's to handle (its
offboard-loss failsafe: hold, then ``offboard_loss_action``); a gust is ridden out. The
VIO lost for good is the mission's (HOLD) and then the FCU's: without a position it
cannot hold, and its position-loss failsafe descends to the floor.

A fault that ends (a duration) and shows as a transient cause (the policy's
``transient``: the VIO, or the FCU link, lost for a while) expects "HOLD, then RESUME,
then completed": handled when the mission completes with every landing inside, whatever
it took (a gap too short for any cause needs no hold). One that ends and is ridden out or
searched for (a packet burst, a gust, a camera blink) must still let the mission complete
with every landing inside ("NONE, then completed"); a packet burst may lose the FCU's
status for long enough to be the link lost for a while, and its HOLD and RESUME are then
the mission's recovery, not an error. Each fault is judged on its own window (from its
start to a few seconds past its end), so a run's faults, apart in time, are judged apart.

What happened is read from what the mission published (its ``/mission/events``: an error
event carries its cause and reaction) and from the FCU's modes; where the vehicle ended
from ground truth (:func:`end_state`). Evaluation only: the app layer.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import Any

from fsm.mission_machine import EventKind, MissionEvent
from fsm.mission_table import ERROR_POLICY, ErrorCause, Reaction
from runtime.parameters import load_parameters
from sim.arena import PAD_SIZE, ArenaSpec
from sim.fault_spec import Fault, FaultKind
from sim.fcu.commander import COMMANDER_NODE_NAME, CommanderParams
from sim.fcu.firmware import Firmware
from sim.world import Crash, Scene, Trajectory

__all__ = ["EXPECTED", "FAULT_SETTLE_S", "NODE_STOP_EXPECTED", "RECOVERS", "RESTART_SURVIVED",
           "EndState", "Expectation", "FaultExpectationError", "FcuFailsafes", "Handler",
           "end_state", "expectation", "fcu_takes_back_within_s", "judge_fault"]

AT_REST_M_S = 0.15  # m/s: slower than this, the vehicle is at rest (landed or holding)
ON_GROUND_M = 0.1  # m: the body this close to its resting height on the pad is down
FAULT_SETTLE_S = 10.0  # s flown on after a fault stopped a run: where the vehicle comes to rest
SETTLE_WINDOW_S = 2.0  # s after a gust in which an error still counts as its doing
RECOVERY_WINDOW_S = 10.0  # s after a fault that ended in which its HOLD may still come


class Handler(Enum):
    """Who must react to a fault."""

    MISSION = "mission"  # the mission's error policy
    FCU = "fcu"  # the flight controller's failsafe
    NOBODY = "nobody"  # ride it out: no error, no crash
    SKIP = "skip"  # the mission searches for the pad's marker, then skips the pad unseen


@dataclass(frozen=True)
class Expectation:
    handler: Handler
    cause: ErrorCause | None = None  # what the mission must report (Handler.MISSION)
    fcu_follows: bool = False
    """A fault that lasts to the end leaves the vehicle to the FCU's failsafe after the
    mission's reaction (VIO lost for good: HOLD, then the position-loss descent), and
    the run must end on the ground."""
    recovers: bool = False
    """The fault ends and its cause is transient: HOLD, then RESUME, then completed."""
    completes: bool = False
    """The fault ends and the mission flies: ridden out (or its pad searched for), the
    mission must then complete with every landing inside."""
    may_show_as: ErrorCause | None = None
    """A transient cause a ridden-out fault may show as (a packet burst that loses the
    FCU's status for ``status_timeout_s``: ``offboard_lost``): its HOLD and RESUME are the
    mission's recovery, not an error."""

    @property
    def reaction(self) -> str:
        """The expected reaction's name: the policy's for the cause, else the handler's."""
        if self.recovers:
            return RECOVERED
        if self.cause is not None:
            return ERROR_POLICY[self.cause].reaction.name
        if self.completes:
            return {Handler.SKIP: "SEARCH, then landed or SKIP"}.get(
                self.handler, "NONE") + ", then completed"
        return {Handler.FCU: "FAILSAFE", Handler.SKIP: "SEARCH, then SKIP"}.get(self.handler,
                                                                             "NONE")


EXPECTED: dict[FaultKind, Expectation] = {
    FaultKind.VIO_STOP: Expectation(Handler.MISSION, ErrorCause.LOCALISATION_LOST,
                                    fcu_follows=True),
    FaultKind.BATTERY_LOW: Expectation(Handler.MISSION, ErrorCause.BATTERY_LOW),
    FaultKind.BATTERY_CRITICAL: Expectation(Handler.MISSION, ErrorCause.BATTERY_CRITICAL),
    FaultKind.OPERATOR_ABORT: Expectation(Handler.MISSION, ErrorCause.OPERATOR_ABORT),
    FaultKind.LINK_LOST: Expectation(Handler.FCU),
    FaultKind.WIND_GUST: Expectation(Handler.NOBODY),
    # a 0.25 m robot below the 1.5 m corridor: the depth camera maps it, the path planner
    # keeps flying over it (its vertical clearance), nothing to react to; a vehicle that
    # hits it is not handled
    FaultKind.ROBOT_ACROSS: Expectation(Handler.NOBODY),
    # the FCU follows the jumped odometry (nothing checks it): the vehicle moves by the
    # jump, unnoticed; a consistency check is a policy the mission lacks (docs/scenarios.md)
    FaultKind.VIO_JUMP: Expectation(Handler.NOBODY),
    FaultKind.VIO_DELAY: Expectation(Handler.NOBODY),  # fused at its sample time (EKF buffer)
    FaultKind.LATENCY_SPIKE: Expectation(Handler.NOBODY),  # below COM_OF_LOSS_T: ride it out
    # enough heartbeats get through; five /fcu/status lost in a row are the link lost
    # for a while to the mission (status_timeout_s): a HOLD, then RESUME
    FaultKind.PACKET_BURST: Expectation(Handler.NOBODY,
                                        may_show_as=ErrorCause.OFFBOARD_LOST),
    FaultKind.CLOCK_JUMP: Expectation(Handler.NOBODY),  # the time sync resets and follows
    # no marker seen in the dark: a landing in the dark searches for its pad, which is
    # landed on if the camera comes back during the search, else skipped; no module
    # reports a black camera (a policy the mission lacks)
    FaultKind.CAMERA_DARK: Expectation(Handler.SKIP),
    FaultKind.DEPTH_DARK: Expectation(Handler.NOBODY),  # the map keeps what it had
    FaultKind.PAD_OCCLUDED: Expectation(Handler.SKIP),
    FaultKind.LIGHT_DROP: Expectation(Handler.NOBODY),  # the contest's dark condition
    FaultKind.ROBOT_ABSENT: Expectation(Handler.MISSION, ErrorCause.ROBOT_NOT_FOUND),
    FaultKind.OPERATOR_SILENT: Expectation(Handler.MISSION, ErrorCause.SEQUENCE_TIMEOUT),
    # a module that stops reporting its health (see NODE_STOP_EXPECTED for the others)
    FaultKind.NODE_STOP: Expectation(Handler.MISSION, ErrorCause.MODULE_SILENT),
}

NODE_STOP_EXPECTED: dict[str, Expectation] = {
    # the offboard setpoint stream stops: the FCU's offboard-loss failsafe, before the
    # mission's watchdog could call the module silent
    "flight_control": Expectation(Handler.FCU),
    "fcu_bridge": Expectation(Handler.FCU),
    # the vision to the FCU stops: as vio_stop for good
    "vio": EXPECTED[FaultKind.VIO_STOP],
    **{name: EXPECTED[FaultKind.NODE_STOP] for name in (
        "aruco_scanner", "mapping", "path_finder", "navigator", "precision_land")},
}
"""``node_stop``'s reaction by node, stopped for good. The mission node and the operator
have none: no module watches the mission (a policy the mission lacks), the operator is not
on board."""

RESTART_SURVIVED = frozenset({"aruco_scanner", "mapping", "path_finder", "navigator",
                              "precision_land", "vio"})
"""The nodes whose restart (``node_stop`` with a duration) the mission survives: HOLD on
their cause (a module silent; the VIO's: the localisation lost), RESUME once they are back
(reporting OK) for the settle time, then completed (the VIO only if back before the FCU's
position-loss failsafe descends: seed 0, ``node_stop@60:5,name=vio`` descended at 63 s onto
a 0.6 m box, judged not handled, as ``vio_stop`` as long). ``flight_control`` too when it is back
before the FCU's offboard-loss failsafe acts (:func:`fcu_takes_back_within_s`); later, and
``fcu_bridge`` (the setpoints and the vision both stop, and a restarted bridge holds the
vision back until its time sync converges again), the FCU's failsafe lands the vehicle
first: their expectation for good."""


def fcu_takes_back_within_s() -> float:
    """How soon [s] after the setpoint stream stops it must stream again for the FCU to
    return to OFFBOARD, not land: the loss (``COM_OF_LOSS_T``) and the hold before the
    action (``COM_FAIL_ACT_T``), less the stream it needs before OFFBOARD is entered."""
    c = load_parameters(CommanderParams, COMMANDER_NODE_NAME)
    return c.offboard_loss_timeout_s + c.failsafe_hold_s - c.offboard_min_stream_s


def _restart_survived(fault: Fault) -> bool:
    name = fault.text("name")
    if name == "flight_control":
        return fault.duration_s is not None and fault.duration_s < fcu_takes_back_within_s()
    return name in RESTART_SURVIVED


RECOVERED = "HOLD, then RESUME, then completed"
RECOVERS: dict[Handler, ErrorCause] = {Handler.FCU: ErrorCause.OFFBOARD_LOST}
"""The transient cause a fault that ends shows as, by its handler when it has no cause of
its own: the FCU's offboard-loss failsafe, ended, is the mission's ``offboard_lost``."""


def expectation(fault: Fault, *, mission: bool = True) -> Expectation:
    """The expected reaction to ``fault`` (``node_stop``: by the node's name); one that
    ends, with a transient cause, recovers when the mission flies (``mission``; a flight
    without it, the navigate or precision-landing scenario, has no one to resume); one
    that ends and is ridden out or searched for lets the mission complete."""
    if fault.kind is FaultKind.NODE_STOP:
        name = fault.text("name")
        if name not in NODE_STOP_EXPECTED:
            raise FaultExpectationError(
                f"{fault.spec()}: no expected reaction for node {name!r} (nodes: "
                f"{', '.join(sorted(NODE_STOP_EXPECTED))})")
        base = NODE_STOP_EXPECTED[name]
    else:
        base = EXPECTED[fault.kind]
    cause = base.cause if base.cause is not None else RECOVERS.get(base.handler)
    if fault.kind is FaultKind.NODE_STOP and not _restart_survived(fault):
        return base  # stopped for good, or back too late: as for good
    if mission and math.isfinite(fault.end_s) and cause is not None \
            and ERROR_POLICY[cause].transient:
        return Expectation(Handler.MISSION, cause, recovers=True)
    if mission and math.isfinite(fault.end_s) and base.handler in (Handler.NOBODY,
                                                                    Handler.SKIP):
        return replace(base, completes=True)
    return base


class FaultExpectationError(ValueError):
    """A fault with no expected reaction; the message names it."""


class EndState(Enum):
    """Where the vehicle was at the end of the run, from ground truth."""

    CRASHED = "crashed"
    LANDED_ON_START_PAD = "landed_on_start_pad"
    LANDED = "landed"  # on the ground elsewhere, at rest
    HOLDING = "holding"  # in the air, at rest
    FLYING = "flying"


def end_state(truth: Trajectory, arena: ArenaSpec, resting_height_m: float,
              crash: Crash | None) -> EndState:
    """The vehicle's state at the last true sample. ``resting_height_m``: the body's
    height above a pad's top when it stands on it."""
    if crash is not None:
        return EndState.CRASHED
    x, y, z = (float(v) for v in truth.position[-1])
    speed = float(math.hypot(*truth.velocity[-1]))
    sx, sy, sz = arena.takeoff_position
    if speed > AT_REST_M_S:
        return EndState.FLYING
    if z - resting_height_m > sz + ON_GROUND_M:
        return EndState.HOLDING
    half = PAD_SIZE / 2.0
    if abs(x - sx) <= half and abs(y - sy) <= half:
        return EndState.LANDED_ON_START_PAD
    return EndState.LANDED


@dataclass
class FcuFailsafes:
    """A world part that notes when the FCU enters a failsafe (truth, for the report)."""

    firmware: Firmware
    name: str = "fcu_failsafes"
    rate_hz: float = 50.0
    entered_s: list[float] = field(default_factory=list)
    _was: bool = False

    def update(self, t_ns: int, scene: Scene) -> None:
        status = self.firmware.status
        now = bool(status is not None and status.failsafe)
        if now and not self._was:
            self.entered_s.append(t_ns / 1e9)
        self._was = now


_END_STATES_OF: dict[Reaction, set[EndState]] = {
    Reaction.HOLD: {EndState.HOLDING, EndState.LANDED, EndState.LANDED_ON_START_PAD},
    Reaction.LAND_NOW: {EndState.LANDED, EndState.LANDED_ON_START_PAD},
    Reaction.RETURN_AND_LAND: {EndState.LANDED_ON_START_PAD},
}


def _cause_of(event: MissionEvent) -> tuple[str, str] | None:
    values = dict(event.values)
    if "cause" in values and "reaction" in values:
        return values["cause"], values["reaction"]
    return None


@dataclass(frozen=True)
class _PadReaction:
    observed: str
    reaction_s: float | None
    skipped: bool  # the pad was skipped
    settled: bool  # a search ended in a landing or a skip (no search: nothing to settle)
    settled_s: float | None = None  # when: the landing or the skip [s]


def _search_then_skip(fault: Fault, events: Sequence[tuple[float, MissionEvent]],
                      skipped: Sequence[tuple[float, int, str]]) -> _PadReaction:
    """What the mission did about a pad it could not see after ``fault`` (the occluded
    pad, or any pad for a dark camera): ``SEARCH pad P`` when a landing failed to see its
    marker (the mission's LANDING_FAILED: the wide search begins), then ``landed on it``
    or ``SKIP pad P: reason``; a skip without a search alone."""
    pad = fault.value("pad") if fault.kind is FaultKind.PAD_OCCLUDED else math.nan

    def mine(t: float, p: int) -> bool:
        return t >= fault.at_s and (math.isnan(pad) or p == int(pad))

    search = next(((t, e.marker_id) for t, e in events
                   if e.kind is EventKind.LANDING_FAILED and mine(t, e.marker_id)), None)
    skip = next(((t, p, r) for t, p, r in skipped if mine(t, p)
                 and (search is None or (p == search[1] and t >= search[0]))), None)
    skip_text = "" if skip is None else f"SKIP pad {skip[1]}: {skip[2]}"
    if search is None:
        return (_PadReaction("none", None, False, True) if skip is None
                else _PadReaction(skip_text, skip[0] - fault.at_s, True, True, skip[0]))
    t0, searched = search
    if skip is not None:
        return _PadReaction(f"SEARCH pad {searched}, then {skip_text}", t0 - fault.at_s,
                            True, True, skip[0])
    landed = next((t for t, e in events
                   if e.kind is EventKind.LANDED and e.marker_id == searched and t >= t0), None)
    return _PadReaction(f"SEARCH pad {searched}" + (", then landed on it" if landed else ""),
                        t0 - fault.at_s, False, landed is not None, landed)


def _recovered(fault: Fault, expected: Expectation,
               events: Sequence[tuple[float, MissionEvent]],
               completed: bool) -> tuple[str, float | None]:
    """What the mission did about a fault that ended: its holds and resumes from the
    fault on (``cause: HOLD, then RESUME``), and ``then completed``."""
    assert expected.cause is not None
    steps = [(t, c) for t, e in events if t >= fault.at_s and (c := _cause_of(e)) is not None]
    # its own hold: not one of a later fault's (a module silent a few seconds into a stop)
    hold = next((t for t, c in steps if c[1] == "HOLD"
                 and t <= fault.end_s + RECOVERY_WINDOW_S), None)
    parts = []
    if hold is not None:
        held_on = next(c[0] for t, c in steps if t == hold and c[1] == "HOLD")
        resumed = any(c[1] == "RESUME" and t >= hold for t, c in steps)
        parts.append(f"{held_on}: HOLD" + (", then RESUME" if resumed else ""))
    if completed:
        parts.append("completed")
    return (", then ".join(parts) or "none"), (None if hold is None else hold - fault.at_s)


def judge_fault(fault: Fault, events: Sequence[tuple[float, MissionEvent]],
                fcu_failsafes: Sequence[float], end: EndState,
                skipped: Sequence[tuple[float, int, str]] = (),
                completed: bool = False, mission: bool = True) -> dict[str, Any]:
    """One fault's entry of the report: ``{kind, at_s, expected, observed, reaction_s,
    end_state, handled}``. ``events``: the mission's (time, event); ``fcu_failsafes``:
    the times the FCU entered a failsafe; ``skipped``: the pads the mission skipped
    (time, pad, reason); ``completed``: the mission completed with every landing inside
    (what a fault that ends, with a transient cause, must still allow); ``mission``: the
    mission flew (:func:`expectation`)."""
    expected = expectation(fault, mission=mission)
    observed, reaction_s = "none", None
    handled = end is not EndState.CRASHED
    if expected.recovers:
        observed, reaction_s = _recovered(fault, expected, events, completed)
        handled = handled and completed
    elif expected.handler is Handler.SKIP:
        pad = _search_then_skip(fault, events, skipped)
        observed, reaction_s = pad.observed, pad.reaction_s
        # an error from the fault's start to its end, or its pad's landing or skip
        until = max(fault.end_s, pad.settled_s or fault.at_s) + SETTLE_WINDOW_S
        causes = [e for te, e in events if fault.at_s <= te <= until
                  and _cause_of(e) is not None]
        # a dark camera may cost no pad (back before a landing, or during its search); an
        # occluded pad must go
        must_skip = fault.kind is FaultKind.PAD_OCCLUDED
        handled = handled and not causes and pad.settled and (pad.skipped or not must_skip)
    elif expected.handler is Handler.FCU:
        fs = next((t for t in fcu_failsafes if fault.at_s <= t <= fault.end_s + 1e-9), None)
        if fs is not None:
            observed, reaction_s = "FAILSAFE", fs - fault.at_s
        handled = handled and fs is not None
    else:
        until = fault.end_s + SETTLE_WINDOW_S if expected.handler is Handler.NOBODY else math.inf
        errors = [(t, c) for t, e in events if fault.at_s <= t <= until
                  and (c := _cause_of(e)) is not None]
        shown = expected.may_show_as
        if shown is not None and any(c[0] == shown.value for _, c in errors):
            # the transient cause it may show as: the mission's recovery, not an error
            errors = [(t, c) for t, c in errors if c[0] != shown.value]
            if not errors:
                observed, reaction_s = _recovered(
                    fault, replace(expected, cause=shown), events, completed=False)
        want = expected.cause.value if expected.cause is not None else None
        final = None if expected.cause is None else ERROR_POLICY[expected.cause].reaction.name
        # the permanent reaction when there is one (a transient cause first holds)
        hit = next(((t, c) for t, c in errors if c == (want, final)),
                   next(((t, c) for t, c in errors if c[0] == want),
                        errors[0] if errors else None))
        if hit is not None:
            t, (cause, reaction) = hit
            observed, reaction_s = f"{cause}: {reaction}", t - fault.at_s
        if expected.cause is None:
            handled = handled and hit is None
        else:
            policy = ERROR_POLICY[expected.cause].reaction
            handled = (handled and hit is not None and hit[1] == (want, policy.name)
                       and end in _END_STATES_OF[policy])
    if expected.completes:
        if completed:
            observed = "completed" if observed == "none" else f"{observed}, then completed"
        handled = handled and completed
    expected_text = (expected.reaction if expected.cause is None
                     else f"{expected.cause.value}: {expected.reaction}")
    if expected.fcu_follows and not math.isfinite(fault.end_s):
        expected_text += ", then FAILSAFE"
        then = next((t for t in fcu_failsafes if t >= fault.at_s), None)
        if then is not None:
            observed += ", then FAILSAFE"
        handled = handled and then is not None and end in _END_STATES_OF[Reaction.LAND_NOW]
    return {"kind": fault.kind.value, "at_s": fault.at_s, "duration_s": fault.duration_s,
            "spec": fault.spec(),
            "expected": expected_text,
            "observed": observed,
            "reaction_s": None if reaction_s is None else round(reaction_s, 3),
            "end_state": end.value, "handled": handled}
