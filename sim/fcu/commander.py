"""The simulated FCU's commander: arming, modes and failsafes as a transition table.

A subset of PX4's commander (``src/modules/commander``) for a vehicle without RC: the
arming state (DISARMED/ARMED) and one of the auto or offboard modes, reported with PX4's
``NAVIGATION_STATE_*`` numbers. :func:`commander_step` is a pure function: the previous
:class:`CommanderState` and one tick's :class:`CommanderInputs` (time, offboard
heartbeat, land detector, battery warning, estimator validity, the vehicle commands
received since the last tick) give the next state, the :class:`CommanderStatus` and one
:class:`VehicleCommandAckData` per command addressed to this vehicle. Time is int
microseconds on the FCU clock. :class:`Commander` keeps the state between ticks.

Every (state, event) pair has a row in :data:`TRANSITIONS`; commands and the commander's
own events (takeoff done, auto-disarm, failsafes) go through the same table. A row says
what happens (stay, go to a state, remember the mode for arming, arm, refuse), which
checks must pass first, and the ack result when a check fails::

    DISARMED (nav_state 4):
      arm               arm if arming else DENIED
      disarm            stay
      mode_offboard     remember OFFBOARD if signal, position else TEMP_REJECTED
      mode_takeoff      remember AUTO_TAKEOFF if position, batt<crit else TEMP_REJECTED
      mode_loiter       remember AUTO_LOITER
      mode_land         refuse (DISARMED)
      mode_rtl          refuse (DISARMED)
      takeoff_done      stay
      auto_disarm       stay
      failsafe_hold     stay
      failsafe_land     stay
      failsafe_rtl      stay
      failsafe_descend  stay
      failsafe_cleared  stay
    AUTO_TAKEOFF (nav_state 17):
      arm               stay
      disarm            go DISARMED if landed else DENIED
      mode_offboard     go OFFBOARD if batt<emerg, signal, position else TEMP_REJECTED
      mode_takeoff      go AUTO_TAKEOFF if batt<emerg, position, batt<crit else TEMP_REJECTED
      mode_loiter       go AUTO_LOITER if batt<emerg, position else TEMP_REJECTED
      mode_land         go AUTO_LAND
      mode_rtl          go AUTO_RTL if batt<emerg, position else TEMP_REJECTED
      takeoff_done      go AUTO_LOITER
      auto_disarm       go DISARMED
      failsafe_hold     go AUTO_LOITER
      failsafe_land     go AUTO_LAND
      failsafe_rtl      go AUTO_RTL
      failsafe_descend  go DESCEND
      failsafe_cleared  stay
    AUTO_LOITER (nav_state 4):
      arm               stay
      disarm            go DISARMED if landed else DENIED
      mode_offboard     go OFFBOARD if batt<emerg, signal, position else TEMP_REJECTED
      mode_takeoff      go AUTO_TAKEOFF if batt<emerg, position, batt<crit else TEMP_REJECTED
      mode_loiter       go AUTO_LOITER if batt<emerg, position else TEMP_REJECTED
      mode_land         go AUTO_LAND
      mode_rtl          go AUTO_RTL if batt<emerg, position else TEMP_REJECTED
      takeoff_done      stay
      auto_disarm       go DISARMED
      failsafe_hold     go AUTO_LOITER
      failsafe_land     go AUTO_LAND
      failsafe_rtl      go AUTO_RTL
      failsafe_descend  go DESCEND
      failsafe_cleared  go OFFBOARD
    OFFBOARD (nav_state 14):
      arm               stay
      disarm            go DISARMED if landed else DENIED
      mode_offboard     go OFFBOARD if batt<emerg, signal, position else TEMP_REJECTED
      mode_takeoff      go AUTO_TAKEOFF if batt<emerg, position, batt<crit else TEMP_REJECTED
      mode_loiter       go AUTO_LOITER if batt<emerg, position else TEMP_REJECTED
      mode_land         go AUTO_LAND
      mode_rtl          go AUTO_RTL if batt<emerg, position else TEMP_REJECTED
      takeoff_done      stay
      auto_disarm       go DISARMED
      failsafe_hold     go AUTO_LOITER
      failsafe_land     go AUTO_LAND
      failsafe_rtl      go AUTO_RTL
      failsafe_descend  go DESCEND
      failsafe_cleared  stay
    AUTO_LAND (nav_state 18):
      arm               stay
      disarm            go DISARMED if landed else DENIED
      mode_offboard     go OFFBOARD if batt<emerg, signal, position else TEMP_REJECTED
      mode_takeoff      go AUTO_TAKEOFF if batt<emerg, position, batt<crit else TEMP_REJECTED
      mode_loiter       go AUTO_LOITER if batt<emerg, position else TEMP_REJECTED
      mode_land         go AUTO_LAND
      mode_rtl          go AUTO_RTL if batt<emerg, position else TEMP_REJECTED
      takeoff_done      stay
      auto_disarm       go DISARMED
      failsafe_hold     stay
      failsafe_land     go AUTO_LAND
      failsafe_rtl      stay
      failsafe_descend  go DESCEND
      failsafe_cleared  stay
    AUTO_RTL (nav_state 5):
      arm               stay
      disarm            go DISARMED if landed else DENIED
      mode_offboard     go OFFBOARD if batt<emerg, signal, position else TEMP_REJECTED
      mode_takeoff      go AUTO_TAKEOFF if batt<emerg, position, batt<crit else TEMP_REJECTED
      mode_loiter       go AUTO_LOITER if batt<emerg, position else TEMP_REJECTED
      mode_land         go AUTO_LAND
      mode_rtl          go AUTO_RTL if batt<emerg, position else TEMP_REJECTED
      takeoff_done      stay
      auto_disarm       go DISARMED
      failsafe_hold     stay
      failsafe_land     go AUTO_LAND
      failsafe_rtl      go AUTO_RTL
      failsafe_descend  go DESCEND
      failsafe_cleared  stay
    DESCEND (nav_state 12):
      arm               stay
      disarm            go DISARMED if landed else DENIED
      mode_offboard     go OFFBOARD if batt<emerg, signal, position else TEMP_REJECTED
      mode_takeoff      go AUTO_TAKEOFF if batt<emerg, position, batt<crit else TEMP_REJECTED
      mode_loiter       go AUTO_LOITER if batt<emerg, position else TEMP_REJECTED
      mode_land         go AUTO_LAND
      mode_rtl          go AUTO_RTL if batt<emerg, position else TEMP_REJECTED
      takeoff_done      stay
      auto_disarm       go DISARMED
      failsafe_hold     stay
      failsafe_land     stay
      failsafe_rtl      stay
      failsafe_descend  go DESCEND
      failsafe_cleared  go AUTO_LOITER

Actions: ``stay`` (no change; a command is ACCEPTED), ``go X`` (enter X), ``remember X``
(disarmed: X becomes the mode entered on arming, PX4's ``nav_state_user_intention``),
``arm`` (arm and enter the remembered mode, AUTO_LOITER unless another was chosen),
``refuse`` (DENIED with the given reason). A failing check answers with the result
after the checks, and ``result_param1`` carries the first failing :class:`DenyReason`.
A force flag (``param2 = 21196`` on ARM_DISARM) skips the checks of ARM and DISARM; a
forced arm whose remembered mode fails its own checks arms into AUTO_LOITER instead.

Checks: ``arming`` = attitude and position valid, battery below CRITICAL, landed, and
the remembered mode's own checks; ``signal`` = the OffboardControlMode heartbeat has been
faster than ``offboard_min_rate_hz`` (2 Hz: gaps below 0.5 s) for more than
``offboard_min_stream_s`` (1 s) and is still fresh; ``position`` = local position and
attitude valid; ``batt<crit`` = battery warning below CRITICAL; ``batt<emerg`` = below
EMERGENCY; ``landed`` = the land detector says landed. TEMP_REJECTED is
TEMPORARILY_REJECTED. Mode changes are refused with TEMPORARILY_REJECTED as in PX4; arming
and disarming with DENIED (PX4 answers TEMPORARILY_REJECTED to a failed arming check too;
DENIED here says the vehicle as it is now will not arm).

Policy, each tick, in this order:

1. heartbeat bookkeeping (the stream restarts at any gap of 1 / offboard_min_rate_hz);
2. commands, in arrival order (each sees the state the previous one left);
3. battery failsafe, when the warning rises while armed (each level acts once per
   flight): LOW warns only; CRITICAL fires ``failsafe_land`` (or ``failsafe_rtl`` with
   ``low_battery_action: return``); EMERGENCY (and FAILED) fires ``failsafe_land``;
   ``low_battery_action: warning`` never acts (PX4 ``COM_LOW_BAT_ACT`` 0 / 2 / 3);
4. offboard loss: in OFFBOARD, no heartbeat for more than ``offboard_loss_timeout_s``
   (``COM_OF_LOSS_T``) fires ``failsafe_hold``; held for ``failsafe_hold_s`` (PX4's
   ``COM_FAIL_ACT_T`` hold before the action), the vehicle then takes
   ``offboard_loss_action`` (``COM_OBL_RC_ACT``: land, return or hold). If the signal is
   back (established again) during the hold, ``failsafe_cleared`` returns to OFFBOARD,
   as PX4's failsafe does within its delay; after the action the failsafe is latched
   until a mode command is accepted (user takeover) or the vehicle disarms;
5. position loss: armed in a mode that needs a local position (all but DESCEND), the
   estimate invalid for ``position_loss_delay_s`` (``COM_POS_FS_DELAY``), or its horizontal
   accuracy worse than ``position_loss_eph_m`` (``COM_POS_FS_EPH``), fires
   ``failsafe_descend`` at once (PX4's mode fallback: RTL and Land need a position too, so
   Descend; no hold delay, since Hold cannot run either). DESCEND levels the vehicle and
   sinks at the landing speed until the land detector says landed (then auto-disarm).
   The position back, ``failsafe_cleared`` holds, then returns to the mode the user chose
   (OFFBOARD with its signal, AUTO_LAND, AUTO_RTL);
6. takeoff done: in AUTO_TAKEOFF, height above home within ``takeoff_acceptance_m`` of
   the target fires ``takeoff_done`` (into AUTO_LOITER);
7. auto-disarm: armed and landed for ``disarm_land_s`` (``COM_DISARM_LAND``) after having
   been airborne since arming, or ``disarm_preflight_s`` (``COM_DISARM_PRFLT``) if not,
   fires ``auto_disarm``; a negative time disables it.

Disarmed, the reported ``nav_state`` is AUTO_LOITER whatever mode is remembered (so a
disarmed vehicle never reports OFFBOARD); ``nav_state_user_intention`` shows the
remembered mode. Disarming forgets it. Home altitude follows the vehicle while disarmed
and is frozen on arming (PX4 sets home on arming); takeoff altitudes (``NAV_TAKEOFF``
param7, AMSL) are relative to it.

Pure module: no runtime, no MuJoCo, no message classes (the node converts
:class:`VehicleCommandData` and :class:`VehicleCommandAckData` to and from px4_msgs).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from enum import Enum, IntEnum
from typing import NamedTuple

from interfaces.px4 import (
    BROADCAST_ID,
    COMPANION_COMPONENT_ID,
    FCU_COMPONENT_ID,
    FCU_SYSTEM_ID,
    FORCE_ARM_DISARM_MAGIC,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    ArmDisarmReason,
    ArmingState,
    BatteryWarning,
    CommandResult,
    NavigationState,
    Px4CustomMainMode,
    Px4CustomSubModeAuto,
    VehicleCmd,
)
from runtime.errors import ParameterError
from runtime.parameters import param, validate_parameters

__all__ = [
    "COMMANDER_NODE_NAME",
    "TRANSITIONS",
    "Action",
    "BatteryFailsafeAction",
    "Check",
    "Commander",
    "CommanderInputs",
    "CommanderOutput",
    "CommanderParams",
    "CommanderState",
    "CommanderStatus",
    "DenyReason",
    "Event",
    "FailsafeReason",
    "FlightState",
    "LandTarget",
    "OffboardLossAction",
    "Reaction",
    "TakeoffTarget",
    "VehicleCommandAckData",
    "VehicleCommandData",
    "commander_step",
    "render_transition_table",
]

COMMANDER_NODE_NAME = "fcu_commander"
"""The top-level key of the commander's section in a ROS 2 parameter file."""


_US_PER_S = 1_000_000


# -- the state machine as data -------------------------------------------------------------


class FlightState(Enum):
    """The commander's states: disarmed, or armed in one mode."""

    DISARMED = "DISARMED"
    AUTO_TAKEOFF = "AUTO_TAKEOFF"
    AUTO_LOITER = "AUTO_LOITER"
    OFFBOARD = "OFFBOARD"
    AUTO_LAND = "AUTO_LAND"
    AUTO_RTL = "AUTO_RTL"
    DESCEND = "DESCEND"  # level, straight down: the landing that needs no position

    @property
    def nav_state(self) -> NavigationState:
        """The PX4 navigation state reported (AUTO_LOITER while disarmed)."""
        return _NAV_STATE[self]

    @property
    def armed(self) -> bool:
        return self is not FlightState.DISARMED


_NAV_STATE = {
    FlightState.DISARMED: NavigationState.AUTO_LOITER,
    FlightState.AUTO_TAKEOFF: NavigationState.AUTO_TAKEOFF,
    FlightState.AUTO_LOITER: NavigationState.AUTO_LOITER,
    FlightState.OFFBOARD: NavigationState.OFFBOARD,
    FlightState.AUTO_LAND: NavigationState.AUTO_LAND,
    FlightState.AUTO_RTL: NavigationState.AUTO_RTL,
    FlightState.DESCEND: NavigationState.DESCEND,
}


class Event(Enum):
    """What the table reacts to: decoded vehicle commands, then the commander's own events."""

    ARM = "arm"
    DISARM = "disarm"
    MODE_OFFBOARD = "mode_offboard"
    MODE_TAKEOFF = "mode_takeoff"
    MODE_LOITER = "mode_loiter"
    MODE_LAND = "mode_land"
    MODE_RTL = "mode_rtl"
    TAKEOFF_DONE = "takeoff_done"
    AUTO_DISARM = "auto_disarm"
    FAILSAFE_HOLD = "failsafe_hold"
    FAILSAFE_LAND = "failsafe_land"
    FAILSAFE_RTL = "failsafe_rtl"
    FAILSAFE_DESCEND = "failsafe_descend"
    FAILSAFE_CLEARED = "failsafe_cleared"

    @property
    def is_command(self) -> bool:
        """The event comes from a vehicle command (and is acknowledged)."""
        return self in _COMMAND_EVENTS


_COMMAND_EVENTS = frozenset(
    {
        Event.ARM,
        Event.DISARM,
        Event.MODE_OFFBOARD,
        Event.MODE_TAKEOFF,
        Event.MODE_LOITER,
        Event.MODE_LAND,
        Event.MODE_RTL,
    }
)
_MODE_EVENTS = {
    Event.MODE_OFFBOARD: FlightState.OFFBOARD,
    Event.MODE_TAKEOFF: FlightState.AUTO_TAKEOFF,
    Event.MODE_LOITER: FlightState.AUTO_LOITER,
    Event.MODE_LAND: FlightState.AUTO_LAND,
    Event.MODE_RTL: FlightState.AUTO_RTL,
}


class Action(Enum):
    """What a table row does."""

    STAY = "stay"
    GO = "go"
    REMEMBER = "remember"
    ARM = "arm"
    REFUSE = "refuse"


class Check(Enum):
    """A precondition of a row (see the module docstring)."""

    ARMING = "arming"
    OFFBOARD_SIGNAL = "signal"
    POSITION = "position"
    BATTERY_NOT_CRITICAL = "batt<crit"
    NOT_BATTERY_EMERGENCY = "batt<emerg"
    LANDED = "landed"


class DenyReason(IntEnum):
    """Why a command was not accepted; sent in the ack's ``result_param1``."""

    NONE = 0
    ATTITUDE_INVALID = 1
    POSITION_INVALID = 2
    BATTERY_CRITICAL = 3
    BATTERY_EMERGENCY = 4
    NOT_LANDED = 5
    OFFBOARD_SIGNAL_NOT_ESTABLISHED = 6
    DISARMED = 7
    UNSUPPORTED_COMMAND = 8
    UNSUPPORTED_MODE = 9
    INVALID_PARAMETER = 10
    TAKEOFF_TOO_HIGH = 11

    @property
    def text(self) -> str:
        return _DENY_TEXT[self]


_DENY_TEXT = {
    DenyReason.NONE: "",
    DenyReason.ATTITUDE_INVALID: "attitude estimate invalid",
    DenyReason.POSITION_INVALID: "local position estimate invalid",
    DenyReason.BATTERY_CRITICAL: "battery level critical",
    DenyReason.BATTERY_EMERGENCY: "battery emergency: landing",
    DenyReason.NOT_LANDED: "not landed",
    DenyReason.OFFBOARD_SIGNAL_NOT_ESTABLISHED: (
        "offboard signal not established (OffboardControlMode above 2 Hz for over 1 s)"
    ),
    DenyReason.DISARMED: "vehicle is disarmed",
    DenyReason.UNSUPPORTED_COMMAND: "command not supported",
    DenyReason.UNSUPPORTED_MODE: "mode not supported",
    DenyReason.INVALID_PARAMETER: "invalid command parameter",
    DenyReason.TAKEOFF_TOO_HIGH: "takeoff altitude above takeoff_max_height_m",
}


@dataclass(frozen=True, slots=True)
class Reaction:
    """One row of :data:`TRANSITIONS`."""

    action: Action
    target: FlightState | None = None
    """State entered (GO) or remembered (REMEMBER)."""
    checks: tuple[Check, ...] = ()
    """Preconditions, evaluated in order; all failures are reported."""
    on_fail: CommandResult = CommandResult.TEMPORARILY_REJECTED
    """Ack result when a check fails."""
    refuse: DenyReason = DenyReason.NONE
    """Reason given by a REFUSE row."""
    note: str = ""
    """Said in the ack of an accepted command that changes nothing."""

    def describe(self) -> str:
        """The row as it reads in the table."""
        if self.action is Action.STAY:
            text = "stay"
        elif self.action is Action.ARM:
            text = "arm"
        elif self.action is Action.REFUSE:
            text = f"refuse ({self.refuse.name})"
        else:
            assert self.target is not None
            text = f"{self.action.value} {self.target.value}"
        if self.checks:
            names = ", ".join(c.value for c in self.checks)
            text += f" if {names} else {_SHORT_RESULT.get(self.on_fail, self.on_fail.name)}"
        return text


_SHORT_RESULT = {CommandResult.TEMPORARILY_REJECTED: "TEMP_REJECTED"}


_STAY = Reaction(Action.STAY)
_ARMED_STATES = tuple(s for s in FlightState if s.armed)
_FLYING_CHECKS = (Check.NOT_BATTERY_EMERGENCY, Check.POSITION)


# The table is built once, at import: mutmut cannot switch a mutant on there (it forks its
# test runs after the import), so these builders are left out of mutation testing. The
# table itself is pinned by the docstring test and the behaviour tests (tests/MUTANTS.md).
# pragma: no mutate start
def _disarmed_rows() -> dict[Event, Reaction]:
    rows = {
        Event.ARM: Reaction(Action.ARM, checks=(Check.ARMING,), on_fail=CommandResult.DENIED),
        Event.DISARM: Reaction(Action.STAY, note="already disarmed"),
        Event.MODE_OFFBOARD: Reaction(
            Action.REMEMBER, FlightState.OFFBOARD, (Check.OFFBOARD_SIGNAL, Check.POSITION)
        ),
        Event.MODE_TAKEOFF: Reaction(
            Action.REMEMBER,
            FlightState.AUTO_TAKEOFF,
            (Check.POSITION, Check.BATTERY_NOT_CRITICAL),
        ),
        Event.MODE_LOITER: Reaction(Action.REMEMBER, FlightState.AUTO_LOITER),
        Event.MODE_LAND: Reaction(Action.REFUSE, refuse=DenyReason.DISARMED),
        Event.MODE_RTL: Reaction(Action.REFUSE, refuse=DenyReason.DISARMED),
    }
    for event in Event:
        if not event.is_command:
            rows[event] = _STAY  # the commander's own events need an armed vehicle
    return rows


def _armed_rows(state: FlightState) -> dict[Event, Reaction]:
    def go(target: FlightState, *checks: Check) -> Reaction:
        return Reaction(Action.GO, target, tuple(checks))

    landing = state in (FlightState.AUTO_LAND, FlightState.AUTO_RTL, FlightState.DESCEND)
    descending = state is FlightState.DESCEND
    return {
        Event.ARM: Reaction(Action.STAY, note="already armed"),
        Event.DISARM: Reaction(
            Action.GO, FlightState.DISARMED, (Check.LANDED,), on_fail=CommandResult.DENIED
        ),
        Event.MODE_OFFBOARD: go(
            FlightState.OFFBOARD,
            Check.NOT_BATTERY_EMERGENCY,
            Check.OFFBOARD_SIGNAL,
            Check.POSITION,
        ),
        Event.MODE_TAKEOFF: go(
            FlightState.AUTO_TAKEOFF, *_FLYING_CHECKS, Check.BATTERY_NOT_CRITICAL
        ),
        Event.MODE_LOITER: go(FlightState.AUTO_LOITER, *_FLYING_CHECKS),
        Event.MODE_LAND: go(FlightState.AUTO_LAND),
        Event.MODE_RTL: go(FlightState.AUTO_RTL, *_FLYING_CHECKS),
        Event.TAKEOFF_DONE: (
            go(FlightState.AUTO_LOITER) if state is FlightState.AUTO_TAKEOFF else _STAY
        ),
        Event.AUTO_DISARM: go(FlightState.DISARMED),
        # never interrupt a landing (or a return, which ends in one) to hold
        Event.FAILSAFE_HOLD: _STAY if landing else go(FlightState.AUTO_LOITER),
        # a descent is already a landing, the one that needs no position
        Event.FAILSAFE_LAND: _STAY if descending else go(FlightState.AUTO_LAND),
        # never climb out of a landing to return
        Event.FAILSAFE_RTL: (
            _STAY if state in (FlightState.AUTO_LAND, FlightState.DESCEND)
            else go(FlightState.AUTO_RTL)
        ),
        Event.FAILSAFE_DESCEND: go(FlightState.DESCEND),
        # the cause is gone: an offboard hold resumes OFFBOARD; a descent holds (the
        # position is back), then the commander returns to the mode the user chose
        Event.FAILSAFE_CLEARED: (
            go(FlightState.OFFBOARD) if state is FlightState.AUTO_LOITER
            else go(FlightState.AUTO_LOITER) if descending else _STAY
        ),
    }


def _build_table() -> dict[tuple[FlightState, Event], Reaction]:
    table: dict[tuple[FlightState, Event], Reaction] = {}
    for event, reaction in _disarmed_rows().items():
        table[(FlightState.DISARMED, event)] = reaction
    for state in _ARMED_STATES:
        for event, reaction in _armed_rows(state).items():
            table[(state, event)] = reaction
    return table


# pragma: no mutate end
TRANSITIONS: Mapping[tuple[FlightState, Event], Reaction] = _build_table()
"""The commander's transition table: one row per (state, event)."""


def render_transition_table() -> str:
    """:data:`TRANSITIONS` as text, one block per state (the module docstring shows it)."""
    width = max(len(e.value) for e in Event)
    lines: list[str] = []
    for state in FlightState:
        lines.append(f"    {state.value} (nav_state {state.nav_state.value}):")
        for event in Event:
            lines.append(f"      {event.value:<{width}}  {TRANSITIONS[(state, event)].describe()}")
    return "\n".join(lines)


# -- parameters ----------------------------------------------------------------------------


class OffboardLossAction(Enum):
    """What follows the hold after offboard loss (PX4 ``COM_OBL_RC_ACT`` 5 / 4 / 3)."""

    HOLD = "hold"
    LAND = "land"
    RETURN = "return"


class BatteryFailsafeAction(Enum):
    """PX4 ``COM_LOW_BAT_ACT``: 0 warning, 2 land (at critical), 3 return at critical then land."""

    WARNING = "warning"
    LAND = "land"
    RETURN = "return"


@dataclass(frozen=True, slots=True)
class CommanderParams:
    """Everything in ``config/fcu_commander.yaml``; defaults are PX4's where PX4 has one."""

    system_id: int = param(FCU_SYSTEM_ID, range=(1, 255))
    """``MAV_SYS_ID``: commands for another system are ignored (0 = broadcast)."""
    component_id: int = param(FCU_COMPONENT_ID, range=(1, 255))
    """``MAV_COMP_ID``: commands for another component are ignored (0 = all)."""
    offboard_min_rate_hz: float = param(2.0, unit="Hz", range=(0.1, 1000.0))
    """The offboard heartbeat must be faster than this (gaps below 1 / rate)."""
    offboard_min_stream_s: float = param(1.0, unit="s", range=(0.0, 60.0))
    """... for longer than this before OFFBOARD can be entered."""
    offboard_loss_timeout_s: float = param(1.0, unit="s", range=(0.0, 60.0))
    """``COM_OF_LOSS_T``: heartbeat silence in OFFBOARD that counts as loss."""
    offboard_loss_action: OffboardLossAction = OffboardLossAction.LAND
    """``COM_OBL_RC_ACT``: action after the hold (hold, land, return)."""
    failsafe_hold_s: float = param(5.0, unit="s", range=(0.0, 60.0))
    """``COM_FAIL_ACT_T``: hold after offboard loss before the action."""
    position_loss_delay_s: float = param(4.5, unit="s", range=(0.0, 60.0))
    """``COM_POS_FS_DELAY``: local position invalid this long in a mode that needs it ->
    the position-loss failsafe (descend). Not PX4's 1 s: PX4's EKF2 dead-reckons for
    ``EKF2_NOAID_TOUT`` (5 s) before it calls the position invalid, ours after its
    ``vision_timeout_us`` (0.5 s), so this is the rest of PX4's 5 s from the last aiding
    to the failsafe (``config/fcu_commander.yaml``)."""
    position_loss_eph_m: float = param(1.0, unit="m", range=(0.01, 1000.0))
    """``COM_POS_FS_EPH``: the horizontal position accuracy (eph) worse than this is a
    position loss at once, without ``position_loss_delay_s``: the estimate's own error
    says it no longer knows where it is. Not PX4's 5 m, which is for the open sky: indoors
    the obstacles are 1 to 2 m away (``config/fcu_commander.yaml``)."""
    low_battery_action: BatteryFailsafeAction = BatteryFailsafeAction.LAND
    """``COM_LOW_BAT_ACT``: warning, land, or return at critical (land at emergency)."""
    disarm_land_s: float = param(2.0, unit="s", range=(-1.0, 20.0))
    """``COM_DISARM_LAND``: landed this long after flight -> disarm; negative: never."""
    disarm_preflight_s: float = param(10.0, unit="s", range=(-1.0, 60.0))
    """``COM_DISARM_PRFLT``: landed this long without taking off -> disarm; negative: never."""
    takeoff_height_m: float = param(2.5, unit="m", range=(0.1, 100.0))
    """``MIS_TAKEOFF_ALT``: takeoff height above home without (or below) a requested one."""
    takeoff_max_height_m: float = param(10.0, unit="m", range=(0.1, 1000.0))
    """Requested takeoff heights above this are refused."""
    takeoff_acceptance_m: float = param(0.3, unit="m", range=(0.01, 10.0))
    """Takeoff is done within this of the target height."""

    def __post_init__(self) -> None:
        validate_parameters(self)
        if self.takeoff_max_height_m < self.takeoff_height_m:
            raise ParameterError(
                f"{self.takeoff_max_height_m!r} is outside the allowed range "
                f"[takeoff_height_m = {self.takeoff_height_m!r}, 1000] m",
                key="takeoff_max_height_m",
            )

    @property
    def offboard_max_gap_us(self) -> int:
        return round(_US_PER_S / self.offboard_min_rate_hz)


# -- inputs and outputs --------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class VehicleCommandData:
    """``px4_msgs/VehicleCommand``, field for field (``timestamp`` as ``timestamp_us``)."""

    command: int
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    param5: float = 0.0
    param6: float = 0.0
    param7: float = 0.0
    target_system: int = FCU_SYSTEM_ID
    target_component: int = FCU_COMPONENT_ID
    source_system: int = FCU_SYSTEM_ID
    source_component: int = COMPANION_COMPONENT_ID
    confirmation: int = 0
    from_external: bool = True
    timestamp_us: int = 0


@dataclass(frozen=True, slots=True)
class VehicleCommandAckData:
    """``px4_msgs/VehicleCommandAck``, plus ``reason`` (text, not sent)."""

    timestamp_us: int
    command: int
    result: CommandResult
    result_param1: int = 0
    """The first :class:`DenyReason` when not accepted, 0 otherwise."""
    result_param2: int = 0
    target_system: int = 0
    """The commanding system (the command's source)."""
    target_component: int = 0
    from_external: bool = False
    reason: str = ""
    """Every failed check, or a note, in words."""


# The records built on every tick (inputs, state, status, output) are named tuples: as
# immutable as frozen dataclasses, built in one call instead of one per field (a 20-field
# frozen dataclass costs the commander's whole step again at 100 Hz).


class CommanderInputs(NamedTuple):
    """One tick's inputs, FCU time."""

    now_us: int
    offboard_heartbeat_us: int | None = None
    """Timestamp of the latest OffboardControlMode received, None if none yet."""
    landed: bool = True
    """``VehicleLandDetected.landed``."""
    battery_warning: BatteryWarning = BatteryWarning.NONE
    attitude_valid: bool = True
    position_valid: bool = True
    """Local position (and velocity) estimate valid."""
    position_eph_m: float = 0.0
    """Its horizontal accuracy [m] (``vehicle_local_position.eph``)."""
    altitude_amsl_m: float = 0.0
    """Altitude [m, up] of the vehicle, NaN if unknown."""
    commands: tuple[VehicleCommandData, ...] = ()
    """Vehicle commands received since the last tick, in arrival order."""


@dataclass(frozen=True, slots=True)
class TakeoffTarget:
    """Where AUTO_TAKEOFF climbs to."""

    altitude_amsl_m: float
    height_above_home_m: float
    yaw: float = math.nan
    """Heading [rad], NaN: keep the current one."""


@dataclass(frozen=True, slots=True)
class LandTarget:
    """Where AUTO_LAND lands (``NAV_LAND`` params); NaN fields: here, as PX4."""

    latitude_deg: float = math.nan
    longitude_deg: float = math.nan
    yaw: float = math.nan


class FailsafeReason(Enum):
    NONE = "none"
    OFFBOARD_LOSS = "offboard_loss"
    BATTERY_CRITICAL = "battery_critical"
    BATTERY_EMERGENCY = "battery_emergency"
    POSITION_LOSS = "position_loss"


class _FailsafePhase(Enum):
    NONE = "none"
    HOLD_DELAY = "hold_delay"  # holding, the action still to come, the cause may clear
    ACTION = "action"  # action taken: latched until a mode command or disarm


class CommanderState(NamedTuple):
    """Everything the commander remembers between ticks."""

    state: FlightState = FlightState.DISARMED
    intention: FlightState = FlightState.AUTO_LOITER
    """Mode entered on arming / the mode the user chose."""
    nav_state_timestamp_us: int = 0
    armed_time_us: int = 0
    takeoff_time_us: int = 0
    latest_arming_reason: ArmDisarmReason = ArmDisarmReason.TRANSITION_TO_STANDBY
    latest_disarming_reason: ArmDisarmReason = ArmDisarmReason.TRANSITION_TO_STANDBY
    home_altitude_amsl_m: float = math.nan
    takeoff_target: TakeoffTarget | None = None
    land_target: LandTarget | None = None
    heartbeat_last_us: int | None = None
    heartbeat_stream_start_us: int | None = None
    failsafe_phase: _FailsafePhase = _FailsafePhase.NONE
    failsafe_reason: FailsafeReason = FailsafeReason.NONE
    failsafe_since_us: int = 0
    battery_handled: BatteryWarning = BatteryWarning.NONE
    """Highest battery warning already acted on this flight."""
    airborne_since_arming: bool = False
    landed_since_us: int | None = None
    position_invalid_since_us: int | None = None
    """When the local position became invalid (None: it is valid)."""


class CommanderStatus(NamedTuple):
    """What the commander publishes (the ``VehicleStatus`` fields it owns, and more)."""

    timestamp_us: int
    state: FlightState
    arming_state: ArmingState
    nav_state: NavigationState
    nav_state_user_intention: NavigationState
    nav_state_timestamp_us: int
    armed_time_us: int
    takeoff_time_us: int
    latest_arming_reason: ArmDisarmReason
    latest_disarming_reason: ArmDisarmReason
    failsafe: bool
    failsafe_reason: FailsafeReason
    pre_flight_checks_pass: bool
    arming_check_failures: tuple[DenyReason, ...]
    offboard_signal_established: bool
    offboard_control_signal_lost: bool
    """``FailsafeFlags.offboard_control_signal_lost``: silent for over COM_OF_LOSS_T."""
    battery_warning: BatteryWarning
    home_altitude_amsl_m: float
    takeoff_target: TakeoffTarget | None
    land_target: LandTarget | None


class CommanderOutput(NamedTuple):
    state: CommanderState
    status: CommanderStatus
    acks: tuple[VehicleCommandAckData, ...]


# -- the step ------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Decoded:
    event: Event
    forced: bool = False
    takeoff_altitude_amsl_m: float = math.nan
    yaw: float = math.nan
    land_target: LandTarget | None = None


_AUTO_SUB_MODE_EVENTS: dict[int | None, Event] = {
    Px4CustomSubModeAuto.TAKEOFF: Event.MODE_TAKEOFF,
    Px4CustomSubModeAuto.LOITER: Event.MODE_LOITER,
    Px4CustomSubModeAuto.RTL: Event.MODE_RTL,
    Px4CustomSubModeAuto.LAND: Event.MODE_LAND,
}


def _rounded(value: float) -> int | None:
    return round(value) if math.isfinite(value) else None


def _decode(cmd: VehicleCommandData) -> _Decoded | tuple[CommandResult, DenyReason]:
    """The event of a command, or why it has none."""
    if cmd.command == VehicleCmd.COMPONENT_ARM_DISARM:
        action = _rounded(cmd.param1)
        forced = _rounded(cmd.param2) == FORCE_ARM_DISARM_MAGIC
        if action == 1:
            return _Decoded(Event.ARM, forced=forced)
        if action == 0:
            return _Decoded(Event.DISARM, forced=forced)
        return CommandResult.DENIED, DenyReason.INVALID_PARAMETER
    if cmd.command == VehicleCmd.DO_SET_MODE:
        base = _rounded(cmd.param1)
        if base is None or not base & MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return CommandResult.UNSUPPORTED, DenyReason.UNSUPPORTED_MODE
        main, sub = _rounded(cmd.param2), _rounded(cmd.param3)
        if main == Px4CustomMainMode.OFFBOARD:
            return _Decoded(Event.MODE_OFFBOARD)
        if main == Px4CustomMainMode.AUTO and sub in _AUTO_SUB_MODE_EVENTS:
            return _Decoded(_AUTO_SUB_MODE_EVENTS[sub])
        return CommandResult.UNSUPPORTED, DenyReason.UNSUPPORTED_MODE
    if cmd.command == VehicleCmd.NAV_TAKEOFF:
        return _Decoded(Event.MODE_TAKEOFF, takeoff_altitude_amsl_m=cmd.param7, yaw=cmd.param4)
    if cmd.command == VehicleCmd.NAV_LAND:
        return _Decoded(
            Event.MODE_LAND,
            land_target=LandTarget(
                latitude_deg=cmd.param5, longitude_deg=cmd.param6, yaw=cmd.param4
            ),
        )
    if cmd.command == VehicleCmd.NAV_RETURN_TO_LAUNCH:
        return _Decoded(Event.MODE_RTL)
    return CommandResult.UNSUPPORTED, DenyReason.UNSUPPORTED_COMMAND


class _Facts(NamedTuple):
    """Everything the checks look at: the answers are a function of these alone (kept per
    combination by :func:`_failures_given`, since a tick's checks rarely differ from the
    previous tick's)."""

    attitude_valid: bool
    position_valid: bool
    signal_established: bool
    battery_warning: BatteryWarning
    landed: bool
    intention: FlightState
    """The mode entered on arming (its checks are part of ``arming``)."""


class _Context(NamedTuple):
    """What the checks look at during one tick."""

    params: CommanderParams
    inputs: CommanderInputs
    signal_established: bool

    def facts(self, s: CommanderState) -> _Facts:
        inp = self.inputs
        return _Facts(inp.attitude_valid, inp.position_valid, self.signal_established,
                      inp.battery_warning, inp.landed, s.intention)


def _signal_established(params: CommanderParams, s: CommanderState, now_us: int) -> bool:
    if s.heartbeat_last_us is None or s.heartbeat_stream_start_us is None:
        return False
    fresh = now_us - s.heartbeat_last_us < params.offboard_max_gap_us
    long_enough = now_us - s.heartbeat_stream_start_us > params.offboard_min_stream_s * _US_PER_S
    return fresh and long_enough


def _signal_lost(params: CommanderParams, s: CommanderState, now_us: int) -> bool:
    if s.heartbeat_last_us is None:
        return True
    return now_us - s.heartbeat_last_us > params.offboard_loss_timeout_s * _US_PER_S


def _check_failures(check: Check, facts: _Facts) -> list[DenyReason]:
    if check is Check.POSITION:
        invalid = []
        if not facts.attitude_valid:
            invalid.append(DenyReason.ATTITUDE_INVALID)
        if not facts.position_valid:
            invalid.append(DenyReason.POSITION_INVALID)
        return invalid
    if check is Check.OFFBOARD_SIGNAL:
        return [] if facts.signal_established else [DenyReason.OFFBOARD_SIGNAL_NOT_ESTABLISHED]
    if check is Check.BATTERY_NOT_CRITICAL:
        critical = facts.battery_warning >= BatteryWarning.CRITICAL
        return [DenyReason.BATTERY_CRITICAL] if critical else []
    if check is Check.NOT_BATTERY_EMERGENCY:
        emergency = facts.battery_warning >= BatteryWarning.EMERGENCY
        return [DenyReason.BATTERY_EMERGENCY] if emergency else []
    if check is Check.LANDED:
        return [] if facts.landed else [DenyReason.NOT_LANDED]
    # Check.ARMING: the vehicle's own checks, then those of the mode it will enter
    checks = [Check.POSITION, Check.BATTERY_NOT_CRITICAL, Check.LANDED]
    checks += [c for c in _mode_checks(facts.intention) if c not in checks]
    return list(_failures_given(tuple(checks), facts))


@functools.cache
def _mode_checks(mode: FlightState) -> tuple[Check, ...]:
    """The checks of choosing ``mode`` while disarmed (those of the table's REMEMBER row;
    the table is constant, so each mode's answer is kept)."""
    event = next(e for e, target in _MODE_EVENTS.items() if target is mode)
    return TRANSITIONS[(FlightState.DISARMED, event)].checks


@functools.cache
def _failures_given(checks: tuple[Check, ...], facts: _Facts) -> tuple[DenyReason, ...]:
    """Every failure of ``checks``, in order, each reason once (pure: kept per argument)."""
    failures: list[DenyReason] = []
    for check in checks:
        failures += [f for f in _check_failures(check, facts) if f not in failures]
    return tuple(failures)


def _failures(
    checks: tuple[Check, ...], ctx: _Context, s: CommanderState
) -> tuple[DenyReason, ...]:
    return _failures_given(checks, ctx.facts(s))


def _enter(s: CommanderState, target: FlightState, now_us: int) -> CommanderState:
    if target is s.state:
        return s
    return s._replace(state=target, nav_state_timestamp_us=now_us)


def _disarm(s: CommanderState, now_us: int, reason: ArmDisarmReason) -> CommanderState:
    s = _enter(s, FlightState.DISARMED, now_us)
    return s._replace(
        intention=FlightState.AUTO_LOITER,
        latest_disarming_reason=reason,
        failsafe_phase=_FailsafePhase.NONE,
        failsafe_reason=FailsafeReason.NONE,
        takeoff_target=None,
        land_target=None,
    )  # the per-flight bookkeeping (battery, airborne, landed) starts again on arming


def _takeoff_target(
    params: CommanderParams, s: CommanderState, decoded: _Decoded
) -> TakeoffTarget | DenyReason:
    """The takeoff target of a MODE_TAKEOFF, or why there is none.

    ``NAV_TAKEOFF`` param7 is an altitude AMSL; NaN (and DO_SET_MODE, which has none) or
    an altitude not above home means ``takeoff_height_m`` above home; above
    ``takeoff_max_height_m`` is refused.
    """
    home = s.home_altitude_amsl_m  # follows the vehicle while disarmed, frozen on arming
    if not math.isfinite(home):
        home = 0.0
    requested = decoded.takeoff_altitude_amsl_m - home
    if not math.isfinite(requested) or requested <= 0.0:
        height = params.takeoff_height_m
    elif requested > params.takeoff_max_height_m:
        return DenyReason.TAKEOFF_TOO_HIGH
    else:
        height = requested
    return TakeoffTarget(altitude_amsl_m=home + height, height_above_home_m=height, yaw=decoded.yaw)


def _handle_command(
    ctx: _Context, s: CommanderState, cmd: VehicleCommandData
) -> tuple[CommanderState, VehicleCommandAckData]:
    now = ctx.inputs.now_us

    def ack(
        result: CommandResult, reasons: Iterable[DenyReason] = (), note: str = ""
    ) -> VehicleCommandAckData:
        reasons = list(reasons)
        text = "; ".join(r.text for r in reasons) if reasons else note
        return VehicleCommandAckData(
            timestamp_us=now,
            command=cmd.command,
            result=result,
            result_param1=int(reasons[0]) if reasons else 0,
            target_system=cmd.source_system,
            target_component=cmd.source_component,
            from_external=cmd.from_external,
            reason=text,
        )

    decoded = _decode(cmd)
    if isinstance(decoded, tuple):
        result, why = decoded
        return s, ack(result, [why])
    row = TRANSITIONS[(s.state, decoded.event)]
    if row.action is Action.REFUSE:
        return s, ack(CommandResult.DENIED, [row.refuse])
    forced = decoded.forced and decoded.event in (Event.ARM, Event.DISARM)
    failures = () if forced else _failures(row.checks, ctx, s)
    if failures:
        return s, ack(row.on_fail, failures)
    if row.action is Action.STAY:
        return s, ack(CommandResult.ACCEPTED, note=row.note)

    takeoff: TakeoffTarget | None = s.takeoff_target
    if decoded.event is Event.MODE_TAKEOFF:
        target = _takeoff_target(ctx.params, s, decoded)
        if isinstance(target, DenyReason):
            return s, ack(CommandResult.DENIED, [target])
        takeoff = target
    reason = (
        ArmDisarmReason.COMMAND_EXTERNAL if cmd.from_external else ArmDisarmReason.COMMAND_INTERNAL
    )
    if row.action is Action.ARM:
        s = s._replace(
            armed_time_us=now,
            latest_arming_reason=reason,
            airborne_since_arming=False,
            landed_since_us=None,
            battery_handled=BatteryWarning.NONE,
        )
        entered = s.intention
        if forced and _failures(_mode_checks(entered), ctx, s):
            entered = FlightState.AUTO_LOITER  # forcing skips the vehicle's checks, not the mode's
            s = s._replace(intention=entered)
        return _enter(s, entered, now), ack(CommandResult.ACCEPTED)
    assert row.target is not None
    if row.target is FlightState.DISARMED:
        return _disarm(s, now, reason), ack(CommandResult.ACCEPTED)
    s = s._replace(intention=row.target, takeoff_target=takeoff)
    if decoded.event is Event.MODE_LAND:
        s = s._replace(land_target=decoded.land_target or LandTarget())
    if row.action is Action.GO:  # a user mode change takes over from any failsafe
        s = s._replace(failsafe_phase=_FailsafePhase.NONE, failsafe_reason=FailsafeReason.NONE)
        s = _enter(s, row.target, now)
    return s, ack(CommandResult.ACCEPTED)


def _fire(s: CommanderState, event: Event, now_us: int) -> CommanderState:
    """Apply one of the commander's own events (never a command) through the table."""
    row = TRANSITIONS[(s.state, event)]
    if row.action is not Action.GO:
        return s
    assert row.target is not None
    if event is Event.AUTO_DISARM:
        reason = (
            ArmDisarmReason.AUTO_DISARM_LAND
            if s.airborne_since_arming
            else ArmDisarmReason.AUTO_DISARM_PREFLIGHT
        )
        return _disarm(s, now_us, reason)
    if event is Event.FAILSAFE_LAND and s.land_target is None:
        s = s._replace(land_target=LandTarget())
    return _enter(s, row.target, now_us)


def _update_heartbeat(
    params: CommanderParams, s: CommanderState, heartbeat_us: int | None
) -> CommanderState:
    if heartbeat_us is None or heartbeat_us == s.heartbeat_last_us:
        return s
    last, start = s.heartbeat_last_us, s.heartbeat_stream_start_us
    if last is None or start is None or not 0 <= heartbeat_us - last < params.offboard_max_gap_us:
        start = heartbeat_us  # first heartbeat, or a gap: the stream starts again
    return s._replace(heartbeat_last_us=heartbeat_us, heartbeat_stream_start_us=start)


def _battery_failsafe(
    params: CommanderParams, s: CommanderState, warning: BatteryWarning, now_us: int
) -> CommanderState:
    if not s.state.armed or warning <= s.battery_handled:
        return s
    s = s._replace(battery_handled=warning)
    action = params.low_battery_action
    if warning < BatteryWarning.CRITICAL or action is BatteryFailsafeAction.WARNING:
        return s
    if warning >= BatteryWarning.EMERGENCY:
        event, reason = Event.FAILSAFE_LAND, FailsafeReason.BATTERY_EMERGENCY
    else:
        event = (
            Event.FAILSAFE_RTL if action is BatteryFailsafeAction.RETURN else Event.FAILSAFE_LAND
        )
        reason = FailsafeReason.BATTERY_CRITICAL
    s = s._replace(
        failsafe_phase=_FailsafePhase.ACTION, failsafe_reason=reason, failsafe_since_us=now_us
    )
    return _fire(s, event, now_us)


def _offboard_failsafe(ctx: _Context, s: CommanderState) -> CommanderState:
    params, now = ctx.params, ctx.inputs.now_us
    if s.state is FlightState.OFFBOARD and _signal_lost(params, s, now):
        s = s._replace(
            failsafe_phase=_FailsafePhase.HOLD_DELAY,
            failsafe_reason=FailsafeReason.OFFBOARD_LOSS,
            failsafe_since_us=now,
        )
        s = _fire(s, Event.FAILSAFE_HOLD, now)
    if not (
        s.failsafe_phase is _FailsafePhase.HOLD_DELAY
        and s.failsafe_reason is FailsafeReason.OFFBOARD_LOSS
    ):
        return s
    if ctx.signal_established and s.state is FlightState.AUTO_LOITER:
        s = s._replace(failsafe_phase=_FailsafePhase.NONE, failsafe_reason=FailsafeReason.NONE)
        return _fire(s, Event.FAILSAFE_CLEARED, now)
    if now - s.failsafe_since_us >= params.failsafe_hold_s * _US_PER_S:
        s = s._replace(failsafe_phase=_FailsafePhase.ACTION)
        event = {
            OffboardLossAction.HOLD: Event.FAILSAFE_HOLD,
            OffboardLossAction.LAND: Event.FAILSAFE_LAND,
            OffboardLossAction.RETURN: Event.FAILSAFE_RTL,
        }[params.offboard_loss_action]
        s = _fire(s, event, now)
    return s


# The modes that need a local position: all but DESCEND (PX4's mode requirements).
_NEEDS_POSITION = frozenset(
    {FlightState.AUTO_TAKEOFF, FlightState.AUTO_LOITER, FlightState.OFFBOARD,
     FlightState.AUTO_LAND, FlightState.AUTO_RTL}
)
# Back from a descent, after the hold: the event that returns to the mode the user chose.
_RESUME_EVENT = {
    FlightState.OFFBOARD: Event.FAILSAFE_CLEARED,
    FlightState.AUTO_LAND: Event.FAILSAFE_LAND,
    FlightState.AUTO_RTL: Event.FAILSAFE_RTL,
}


def _position_failsafe(ctx: _Context, s: CommanderState) -> CommanderState:
    """PX4's position-loss failsafe for a multicopter (commander's mode fallback,
    ``src/modules/commander/failsafe/failsafe.cpp`` ``checkModeFallback`` and
    ``framework.cpp`` ``getSelectedAction``): a mode that cannot run for want of a
    local position falls back to RTL, which needs one too, then Land (idem), then
    Descend, which needs attitude only; the hold delay (``COM_FAIL_ACT_T``) is skipped
    because Hold cannot run either. The loss counts after ``position_loss_delay_s``
    (PX4 <= 1.13's ``COM_POS_FS_DELAY``; ours is set so that with the estimator's vision
    timeout it adds up to PX4's ``EKF2_NOAID_TOUT``, 5 s from the last vision sample), or
    at once when the estimate's eph passes ``position_loss_eph_m`` (``COM_POS_FS_EPH``:
    dead reckoning, the filter's variance gets there about 2.9 s after the last sample).
    The fallback clears with its cause (``ClearCondition::WhenConditionClears``): the
    position back, the vehicle holds and returns to the mode the user chose (OFFBOARD
    only with its signal)."""
    params, inputs, now = ctx.params, ctx.inputs, ctx.inputs.now_us
    too_coarse = inputs.position_eph_m > params.position_loss_eph_m
    if inputs.position_valid and not too_coarse:
        if s.position_invalid_since_us is not None:
            s = s._replace(position_invalid_since_us=None)
        if s.state is FlightState.DESCEND and s.failsafe_reason is FailsafeReason.POSITION_LOSS:
            s = s._replace(failsafe_phase=_FailsafePhase.NONE, failsafe_reason=FailsafeReason.NONE)
            s = _fire(s, Event.FAILSAFE_CLEARED, now)
            back = _RESUME_EVENT.get(s.intention)
            if back is Event.FAILSAFE_CLEARED and not ctx.signal_established:
                back = None
            if back is not None:
                s = _fire(s, back, now)
        return s
    since = s.position_invalid_since_us
    if since is None:
        since = now
        s = s._replace(position_invalid_since_us=now)
    lost = too_coarse or now - since >= params.position_loss_delay_s * _US_PER_S
    if s.state in _NEEDS_POSITION and lost:
        s = s._replace(failsafe_phase=_FailsafePhase.ACTION,
                       failsafe_reason=FailsafeReason.POSITION_LOSS, failsafe_since_us=now)
        s = _fire(s, Event.FAILSAFE_DESCEND, now)
    return s


def _takeoff_done(
    params: CommanderParams, s: CommanderState, inputs: CommanderInputs
) -> CommanderState:
    if s.state is not FlightState.AUTO_TAKEOFF or s.takeoff_target is None:
        return s
    height = inputs.altitude_amsl_m - s.home_altitude_amsl_m
    target = s.takeoff_target.height_above_home_m - params.takeoff_acceptance_m
    if math.isfinite(height) and height >= target:
        return _fire(s, Event.TAKEOFF_DONE, inputs.now_us)
    return s


def _auto_disarm(
    params: CommanderParams, s: CommanderState, inputs: CommanderInputs
) -> CommanderState:
    if not s.state.armed:
        return s
    now = inputs.now_us
    if not inputs.landed:
        if not s.airborne_since_arming:
            s = s._replace(airborne_since_arming=True, takeoff_time_us=now)
        return s._replace(landed_since_us=None) if s.landed_since_us is not None else s
    if s.landed_since_us is None:
        s = s._replace(landed_since_us=now)
    timeout_s = params.disarm_land_s if s.airborne_since_arming else params.disarm_preflight_s
    assert s.landed_since_us is not None
    if timeout_s >= 0.0 and now - s.landed_since_us >= timeout_s * _US_PER_S:
        return _fire(s, Event.AUTO_DISARM, now)
    return s


def commander_step(
    params: CommanderParams, state: CommanderState, inputs: CommanderInputs
) -> CommanderOutput:
    """One commander tick (see the module docstring for the order of things)."""
    now = inputs.now_us
    s = _update_heartbeat(params, state, inputs.offboard_heartbeat_us)
    if not s.state.armed:
        s = s._replace(home_altitude_amsl_m=inputs.altitude_amsl_m)
    ctx = _Context(params, inputs, _signal_established(params, s, now))

    acks: list[VehicleCommandAckData] = []
    for cmd in inputs.commands:
        if cmd.target_system not in (BROADCAST_ID, params.system_id) or (
            cmd.target_component not in (BROADCAST_ID, params.component_id)
        ):
            continue  # for someone else: PX4 neither executes nor acknowledges it
        s, ack = _handle_command(ctx, s, cmd)
        acks.append(ack)

    s = _battery_failsafe(params, s, inputs.battery_warning, now)
    s = _offboard_failsafe(ctx, s)
    s = _position_failsafe(ctx, s)
    s = _takeoff_done(params, s, inputs)
    s = _auto_disarm(params, s, inputs)

    arming_failures = _failures((Check.ARMING,), ctx, s)
    armed = s.state.armed
    status = CommanderStatus(
        timestamp_us=now,
        state=s.state,
        arming_state=ArmingState.ARMED if armed else ArmingState.DISARMED,
        nav_state=s.state.nav_state,
        nav_state_user_intention=s.intention.nav_state,
        nav_state_timestamp_us=s.nav_state_timestamp_us,
        armed_time_us=s.armed_time_us if armed else 0,
        takeoff_time_us=s.takeoff_time_us if armed else 0,
        latest_arming_reason=s.latest_arming_reason,
        latest_disarming_reason=s.latest_disarming_reason,
        failsafe=s.failsafe_phase is not _FailsafePhase.NONE,
        failsafe_reason=s.failsafe_reason,
        pre_flight_checks_pass=not arming_failures,
        arming_check_failures=arming_failures,
        offboard_signal_established=ctx.signal_established,
        offboard_control_signal_lost=_signal_lost(params, s, now),
        battery_warning=inputs.battery_warning,
        home_altitude_amsl_m=s.home_altitude_amsl_m,
        takeoff_target=s.takeoff_target,
        land_target=s.land_target if s.state is FlightState.AUTO_LAND else None,
    )
    return CommanderOutput(state=s, status=status, acks=tuple(acks))


class Commander:
    """Keeps the :class:`CommanderState` between ticks of :func:`commander_step`."""

    def __init__(self, params: CommanderParams | None = None) -> None:
        self.params = params if params is not None else CommanderParams()
        self.state = CommanderState()
        self._last_now_us: int | None = None

    def step(self, inputs: CommanderInputs) -> CommanderOutput:
        """One tick; ``inputs.now_us`` must not go back in time."""
        if self._last_now_us is not None and inputs.now_us < self._last_now_us:
            raise ValueError(
                f"now_us: {inputs.now_us} is before the previous tick {self._last_now_us}"
            )
        self._last_now_us = inputs.now_us
        out = commander_step(self.params, self.state, inputs)
        self.state = out.state
        return out
