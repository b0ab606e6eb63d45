"""Commander: arming checks, the offboard heartbeat rule, failsafes, auto-disarm, the table."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sim.fcu.commander as commander_module
from interfaces.px4 import (
    FORCE_ARM_DISARM_MAGIC,
    ArmDisarmReason,
    ArmingState,
    BatteryWarning,
    CommandResult,
    NavigationState,
    VehicleCmd,
)
from runtime.errors import ParameterError
from runtime.parameters import load_parameters, parameters_from_mapping, parameters_from_yaml
from sim.fcu.commander import (
    COMMANDER_NODE_NAME,
    TRANSITIONS,
    BatteryFailsafeAction,
    Commander,
    CommanderInputs,
    CommanderOutput,
    CommanderParams,
    DenyReason,
    Event,
    FailsafeReason,
    FlightState,
    OffboardLossAction,
    VehicleCommandData,
    render_transition_table,
)
from sim.fcu.estimator import ESTIMATOR_NODE_NAME, EstimatorParams

MS = 1000
S = 1_000_000
TICK_US = 20 * MS  # 50 Hz commander in these tests
HOME_AMSL_M = 100.0


def arm(force: bool = False) -> VehicleCommandData:
    return VehicleCommandData(
        VehicleCmd.COMPONENT_ARM_DISARM,
        param1=1.0,
        param2=float(FORCE_ARM_DISARM_MAGIC) if force else 0.0,
    )


def disarm(force: bool = False) -> VehicleCommandData:
    return VehicleCommandData(
        VehicleCmd.COMPONENT_ARM_DISARM,
        param1=0.0,
        param2=float(FORCE_ARM_DISARM_MAGIC) if force else 0.0,
    )


def set_offboard() -> VehicleCommandData:
    return VehicleCommandData(VehicleCmd.DO_SET_MODE, param1=1.0, param2=6.0)


def set_auto(sub_mode: int) -> VehicleCommandData:
    return VehicleCommandData(VehicleCmd.DO_SET_MODE, param1=1.0, param2=4.0, param3=sub_mode)


def takeoff(altitude_amsl_m: float = math.nan) -> VehicleCommandData:
    return VehicleCommandData(VehicleCmd.NAV_TAKEOFF, param4=math.nan, param7=altitude_amsl_m)


def land() -> VehicleCommandData:
    return VehicleCommandData(
        VehicleCmd.NAV_LAND, param4=math.nan, param5=math.nan, param6=math.nan
    )


@dataclass
class Bench:
    """Drives a Commander tick by tick with a scripted world around it."""

    params: CommanderParams = field(default_factory=CommanderParams)
    now_us: int = 0
    heartbeat_period_us: int | None = None
    """Offboard heartbeat period while streaming; None: no heartbeat."""
    heartbeat_start_us: int = 0
    landed: bool = True
    altitude_amsl_m: float = HOME_AMSL_M
    battery: BatteryWarning = BatteryWarning.NONE
    attitude_valid: bool = True
    position_valid: bool = True
    eph_m: float = 0.05
    last_heartbeat_us: int | None = None
    commander: Commander = field(init=False)

    def __post_init__(self) -> None:
        self.commander = Commander(self.params)

    def stream(self, period_us: int | None) -> None:
        """Start (or stop, with None) a heartbeat at this period, from now."""
        self.heartbeat_period_us = period_us
        self.heartbeat_start_us = self.now_us

    def _heartbeat(self) -> int | None:
        if self.heartbeat_period_us is not None:
            since = self.now_us - self.heartbeat_start_us
            self.last_heartbeat_us = (
                self.heartbeat_start_us
                + since // self.heartbeat_period_us * self.heartbeat_period_us
            )
        return self.last_heartbeat_us

    def tick(self, *commands: VehicleCommandData) -> CommanderOutput:
        before = self.commander.state.state
        out = self.commander.step(
            CommanderInputs(
                now_us=self.now_us,
                offboard_heartbeat_us=self._heartbeat(),
                landed=self.landed,
                battery_warning=self.battery,
                attitude_valid=self.attitude_valid,
                position_valid=self.position_valid,
                position_eph_m=self.eph_m,
                altitude_amsl_m=self.altitude_amsl_m,
                commands=commands,
            )
        )
        # invariants of every status: a state change is stamped with its tick, and a
        # failsafe reason is given exactly while a failsafe is active
        if out.status.state is not before:
            assert out.status.nav_state_timestamp_us == self.now_us, (before, out.status.state)
        assert (out.status.failsafe_reason is not FailsafeReason.NONE) == out.status.failsafe
        self.now_us += TICK_US
        return out

    def run(self, duration_us: int) -> list[CommanderOutput]:
        """Tick for ``duration_us`` without commands."""
        return [self.tick() for _ in range(duration_us // TICK_US)]

    def command(self, cmd: VehicleCommandData) -> CommanderOutput:
        out = self.tick(cmd)
        assert len(out.acks) == 1, out.acks
        return out

    def airborne(self, height_m: float = 2.0) -> None:
        self.landed = False
        self.altitude_amsl_m = HOME_AMSL_M + height_m


def armed_in_offboard(params: CommanderParams | None = None) -> Bench:
    """Armed, flying in OFFBOARD with a 10 Hz heartbeat."""
    bench = Bench(params=params or CommanderParams())
    bench.stream(100 * MS)
    bench.run(1200 * MS)
    assert bench.command(arm()).acks[0].result is CommandResult.ACCEPTED
    out = bench.command(set_offboard())
    assert out.acks[0].result is CommandResult.ACCEPTED, out.acks[0]
    bench.airborne()
    bench.run(500 * MS)
    return bench


# -- arming ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("attitude_valid", "position_valid", "reason"),
    [
        (True, False, DenyReason.POSITION_INVALID),
        (False, True, DenyReason.ATTITUDE_INVALID),
    ],
)
def test_arming_is_denied_with_an_invalid_estimator(
    attitude_valid: bool, position_valid: bool, reason: DenyReason
) -> None:
    bench = Bench(attitude_valid=attitude_valid, position_valid=position_valid)
    out = bench.command(arm())
    ack = out.acks[0]
    assert ack.result is CommandResult.DENIED
    assert ack.result_param1 == reason
    assert reason.text in ack.reason
    assert out.status.arming_state is ArmingState.DISARMED
    assert not out.status.pre_flight_checks_pass
    assert reason in out.status.arming_check_failures


@pytest.mark.parametrize("warning", [BatteryWarning.CRITICAL, BatteryWarning.EMERGENCY])
def test_arming_is_denied_with_a_critical_battery(warning: BatteryWarning) -> None:
    bench = Bench(battery=warning)
    out = bench.command(arm())
    assert out.acks[0].result is CommandResult.DENIED
    assert out.acks[0].result_param1 == DenyReason.BATTERY_CRITICAL
    assert "battery" in out.acks[0].reason
    assert out.status.arming_state is ArmingState.DISARMED


def test_arming_is_denied_when_not_landed_and_every_failure_is_named() -> None:
    bench = Bench(landed=False, position_valid=False)
    ack = bench.command(arm()).acks[0]
    assert ack.result is CommandResult.DENIED
    assert ack.result_param1 == DenyReason.POSITION_INVALID
    assert DenyReason.NOT_LANDED.text in ack.reason
    assert DenyReason.POSITION_INVALID.text in ack.reason


def test_force_arm_skips_the_checks() -> None:
    bench = Bench(position_valid=False)
    out = bench.command(arm(force=True))
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.arming_state is ArmingState.ARMED


def test_arming_enters_hold_and_arming_again_is_accepted_without_change() -> None:
    bench = Bench()
    assert bench.run(100 * MS)[-1].status.pre_flight_checks_pass
    out = bench.command(arm())
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.arming_state is ArmingState.ARMED
    assert out.status.nav_state is NavigationState.AUTO_LOITER
    assert out.status.latest_arming_reason is ArmDisarmReason.COMMAND_EXTERNAL
    again = bench.command(arm())
    assert again.acks[0].result is CommandResult.ACCEPTED
    assert again.acks[0].reason == "already armed"
    assert again.status.armed_time_us == out.status.armed_time_us


def test_disarm_in_the_air_is_denied_unless_forced() -> None:
    bench = Bench()
    bench.command(arm())
    bench.airborne()
    ack = bench.command(disarm()).acks[0]
    assert ack.result is CommandResult.DENIED
    assert ack.result_param1 == DenyReason.NOT_LANDED
    out = bench.command(disarm(force=True))
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.arming_state is ArmingState.DISARMED


def test_arm_param1_other_than_0_or_1_is_denied_as_invalid() -> None:
    bench = Bench()
    cmd = VehicleCommandData(VehicleCmd.COMPONENT_ARM_DISARM, param1=2.0)
    ack = bench.command(cmd).acks[0]
    assert ack.result is CommandResult.DENIED
    assert ack.result_param1 == DenyReason.INVALID_PARAMETER


# -- the offboard heartbeat rule ------------------------------------------------------------


def test_offboard_is_refused_without_a_heartbeat() -> None:
    bench = Bench()
    bench.command(arm())
    out = bench.command(set_offboard())
    assert out.acks[0].result is CommandResult.TEMPORARILY_REJECTED
    assert out.acks[0].result_param1 == DenyReason.OFFBOARD_SIGNAL_NOT_ESTABLISHED
    assert out.status.nav_state is NavigationState.AUTO_LOITER


def test_offboard_is_accepted_only_after_more_than_1_s_of_10_hz_heartbeat() -> None:
    bench = Bench()
    bench.command(arm())
    bench.stream(100 * MS)
    bench.run(900 * MS)
    early = bench.command(set_offboard())
    assert early.acks[0].result is CommandResult.TEMPORARILY_REJECTED, "0.9 s is not enough"
    bench.run(200 * MS)
    out = bench.command(set_offboard())
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.nav_state is NavigationState.OFFBOARD
    assert out.status.offboard_signal_established


def test_offboard_is_rejected_with_a_1_hz_heartbeat() -> None:
    bench = Bench()
    bench.command(arm())
    bench.stream(1 * S)
    for _ in range(5):
        bench.run(480 * MS)
        out = bench.command(set_offboard())
        assert out.acks[0].result is CommandResult.TEMPORARILY_REJECTED, "1 Hz is below 2 Hz"
        assert not out.status.offboard_signal_established


def test_offboard_chosen_while_disarmed_is_entered_on_arming_never_reported_disarmed() -> None:
    """px4_ros_com's order: stream setpoints, DO_SET_MODE offboard, then arm."""
    bench = Bench()
    bench.stream(100 * MS)
    bench.run(1200 * MS)
    out = bench.command(set_offboard())
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.arming_state is ArmingState.DISARMED
    assert out.status.nav_state is not NavigationState.OFFBOARD
    assert out.status.nav_state_user_intention is NavigationState.OFFBOARD
    armed = bench.command(arm())
    assert armed.acks[0].result is CommandResult.ACCEPTED
    assert armed.status.nav_state is NavigationState.OFFBOARD


def test_arming_into_offboard_needs_the_signal_still_there() -> None:
    bench = Bench()
    bench.stream(100 * MS)
    bench.run(1200 * MS)
    bench.command(set_offboard())
    bench.stream(None)
    bench.run(600 * MS)
    ack = bench.command(arm()).acks[0]
    assert ack.result is CommandResult.DENIED
    assert ack.result_param1 == DenyReason.OFFBOARD_SIGNAL_NOT_ESTABLISHED


def test_the_offboard_stream_must_last_strictly_more_than_offboard_min_stream_s() -> None:
    """Exactly 1 s of a 10 Hz heartbeat is not enough; one microsecond more is."""
    params = CommanderParams(offboard_min_stream_s=1.0, offboard_min_rate_hz=2.0)
    commander = Commander(params)
    start = 5 * S
    for beat in range(11):  # heartbeats at start, start + 0.1 s, ..., start + 1 s
        now = start + beat * 100 * MS
        out = commander.step(CommanderInputs(now_us=now, offboard_heartbeat_us=now))
    assert not out.status.offboard_signal_established, "1 s is not more than 1 s"
    exactly = commander.step(
        CommanderInputs(now_us=start + 1 * S, offboard_heartbeat_us=start + 1 * S,
                        commands=(set_offboard(),))
    )  # fmt: skip
    assert exactly.acks[0].result is CommandResult.TEMPORARILY_REJECTED
    assert exactly.acks[0].result_param1 == DenyReason.OFFBOARD_SIGNAL_NOT_ESTABLISHED
    later = commander.step(
        CommanderInputs(now_us=start + 1 * S + 1, offboard_heartbeat_us=start + 1 * S,
                        commands=(set_offboard(),))
    )  # fmt: skip
    assert later.status.offboard_signal_established
    assert later.acks[0].result is CommandResult.ACCEPTED


def test_a_gap_in_the_heartbeat_restarts_the_stream() -> None:
    """A gap of 1 / offboard_min_rate_hz (0.5 s) restarts the 1 s count from the next beat."""
    commander = Commander(CommanderParams())
    beats = [0, 100 * MS, 200 * MS, 700 * MS, 800 * MS, 1300 * MS, 1400 * MS, 1500 * MS]
    for beat in beats:  # 0.5 s gaps after 200 ms and after 800 ms
        out = commander.step(CommanderInputs(now_us=beat, offboard_heartbeat_us=beat))
        assert not out.status.offboard_signal_established
    for beat in range(1600 * MS, 2400 * MS, 100 * MS):
        out = commander.step(CommanderInputs(now_us=beat, offboard_heartbeat_us=beat))
    assert not out.status.offboard_signal_established, "only 1.0 s since the restart at 1.3 s"
    out = commander.step(CommanderInputs(now_us=2400 * MS, offboard_heartbeat_us=2400 * MS))
    assert out.status.offboard_signal_established


def _streamed_10_hz(commander: Commander, until_us: int) -> int:
    """Heartbeats every 100 ms from 0 to ``until_us``, each received when sent; the last."""
    for beat in range(0, until_us + 1, 100 * MS):
        commander.step(CommanderInputs(now_us=beat, offboard_heartbeat_us=beat))
    return until_us


@pytest.mark.parametrize(("silence_us", "fresh"), [(500 * MS - 1, True), (500 * MS, False)])
def test_the_signal_is_fresh_only_while_the_last_heartbeat_is_under_the_max_gap_old(
    silence_us: int, fresh: bool
) -> None:
    """Established also means still fresh: the last heartbeat less than
    1 / offboard_min_rate_hz (0.5 s) ago. Exactly 0.5 s of silence is stale."""
    params = CommanderParams(offboard_min_rate_hz=2.0, offboard_min_stream_s=1.0)
    commander = Commander(params)
    last = _streamed_10_hz(commander, 1500 * MS)  # a 1.5 s stream: long enough
    out = commander.step(
        CommanderInputs(now_us=last + silence_us, offboard_heartbeat_us=last,
                        commands=(arm(), set_offboard()))
    )  # fmt: skip
    assert out.status.offboard_signal_established is fresh
    mode = out.acks[1]
    if fresh:
        assert mode.result is CommandResult.ACCEPTED
        assert out.status.nav_state is NavigationState.OFFBOARD
    else:
        assert mode.result is CommandResult.TEMPORARILY_REJECTED
        assert mode.result_param1 == DenyReason.OFFBOARD_SIGNAL_NOT_ESTABLISHED
        assert out.status.nav_state is NavigationState.AUTO_LOITER


# -- offboard loss --------------------------------------------------------------------------


def test_offboard_loss_holds_then_lands_after_the_configured_time() -> None:
    params = CommanderParams(failsafe_hold_s=3.0, offboard_loss_timeout_s=1.0)
    bench = armed_in_offboard(params)
    bench.stream(None)
    lost_at = bench.last_heartbeat_us
    assert lost_at is not None
    outs = bench.run(6 * S)
    hold = next(o for o in outs if o.status.nav_state is not NavigationState.OFFBOARD)
    assert hold.status.nav_state is NavigationState.AUTO_LOITER
    assert hold.status.failsafe
    assert hold.status.failsafe_reason is FailsafeReason.OFFBOARD_LOSS
    assert 1 * S < hold.status.timestamp_us - lost_at <= 1 * S + TICK_US
    landing = next(o for o in outs if o.status.nav_state is NavigationState.AUTO_LAND)
    assert landing.status.failsafe
    assert 3 * S <= landing.status.timestamp_us - hold.status.timestamp_us <= 3 * S + TICK_US
    assert outs[-1].status.nav_state is NavigationState.AUTO_LAND


def test_offboard_is_lost_only_after_more_than_com_of_loss_t_of_silence() -> None:
    """Exactly offboard_loss_timeout_s (1 s) without a heartbeat is not yet a loss; one
    microsecond more is: the hold failsafe starts on that tick."""
    params = CommanderParams(offboard_loss_timeout_s=1.0)
    commander = Commander(params)
    last = _streamed_10_hz(commander, 1500 * MS)
    commander.step(CommanderInputs(now_us=last, offboard_heartbeat_us=last,
                                   commands=(arm(), set_offboard())))
    assert commander.state.state is FlightState.OFFBOARD
    at = commander.step(CommanderInputs(now_us=last + 1 * S, offboard_heartbeat_us=last,
                                        landed=False))
    assert not at.status.offboard_control_signal_lost, "1 s is not more than 1 s"
    assert at.status.nav_state is NavigationState.OFFBOARD and not at.status.failsafe
    past = commander.step(CommanderInputs(now_us=last + 1 * S + 1, offboard_heartbeat_us=last,
                                          landed=False))
    assert past.status.offboard_control_signal_lost
    assert past.status.nav_state is NavigationState.AUTO_LOITER
    assert past.status.failsafe_reason is FailsafeReason.OFFBOARD_LOSS


def test_offboard_back_during_the_hold_resumes_offboard() -> None:
    bench = armed_in_offboard(CommanderParams(failsafe_hold_s=5.0))
    bench.stream(None)
    bench.run(1500 * MS)
    assert bench.tick().status.nav_state is NavigationState.AUTO_LOITER
    bench.stream(100 * MS)
    outs = bench.run(1500 * MS)
    assert outs[-1].status.nav_state is NavigationState.OFFBOARD
    assert not outs[-1].status.failsafe
    assert all(o.status.nav_state is not NavigationState.AUTO_LAND for o in outs)


def test_offboard_loss_action_hold_keeps_holding() -> None:
    bench = armed_in_offboard(
        CommanderParams(failsafe_hold_s=1.0, offboard_loss_action=OffboardLossAction.HOLD)
    )
    bench.stream(None)
    outs = bench.run(5 * S)
    assert outs[-1].status.nav_state is NavigationState.AUTO_LOITER
    assert outs[-1].status.failsafe


def test_offboard_loss_action_return_returns_after_the_hold() -> None:
    bench = armed_in_offboard(
        CommanderParams(failsafe_hold_s=1.0, offboard_loss_action=OffboardLossAction.RETURN)
    )
    bench.stream(None)
    outs = bench.run(4 * S)
    states = [o.status.nav_state for o in outs]
    hold = states.index(NavigationState.AUTO_LOITER)
    rtl = states.index(NavigationState.AUTO_RTL)
    assert hold < rtl, "hold first, then return"
    assert outs[rtl].status.timestamp_us - outs[hold].status.timestamp_us == 1 * S
    assert set(states[rtl:]) == {NavigationState.AUTO_RTL}
    assert outs[-1].status.failsafe_reason is FailsafeReason.OFFBOARD_LOSS


def test_a_mode_command_takes_over_from_the_failsafe() -> None:
    bench = armed_in_offboard(CommanderParams(failsafe_hold_s=1.0))
    bench.stream(None)
    bench.run(3 * S)
    assert bench.tick().status.nav_state is NavigationState.AUTO_LAND
    out = bench.command(set_auto(3))
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.nav_state is NavigationState.AUTO_LOITER
    assert not out.status.failsafe


# -- takeoff, land, auto-disarm -------------------------------------------------------------


def test_takeoff_climbs_to_the_requested_altitude_then_holds() -> None:
    bench = Bench()
    bench.command(arm())
    out = bench.command(takeoff(HOME_AMSL_M + 1.5))
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.nav_state is NavigationState.AUTO_TAKEOFF
    target = out.status.takeoff_target
    assert target is not None
    assert target.height_above_home_m == pytest.approx(1.5)
    assert target.altitude_amsl_m == pytest.approx(HOME_AMSL_M + 1.5)
    bench.landed = False
    airborne_at = bench.now_us
    for height in (0.3, 0.6, 0.9, 1.1):
        bench.altitude_amsl_m = HOME_AMSL_M + height
        assert bench.tick().status.nav_state is NavigationState.AUTO_TAKEOFF
    bench.altitude_amsl_m = HOME_AMSL_M + 1.25  # within takeoff_acceptance_m (0.3)
    out = bench.tick()
    assert out.status.nav_state is NavigationState.AUTO_LOITER
    assert out.status.takeoff_time_us == airborne_at, "the first tick the vehicle was not landed"


def test_takeoff_without_altitude_uses_the_default_height_and_too_high_is_denied() -> None:
    bench = Bench()
    bench.command(arm())
    target = bench.command(takeoff()).status.takeoff_target
    assert target is not None
    assert target.height_above_home_m == CommanderParams().takeoff_height_m
    ack = bench.command(takeoff(HOME_AMSL_M + 50.0)).acks[0]
    assert ack.result is CommandResult.DENIED
    assert ack.result_param1 == DenyReason.TAKEOFF_TOO_HIGH


@pytest.mark.parametrize(
    ("requested_m", "expected_m"),
    [
        (0.0, 2.5),  # not above home: the default height
        (-3.0, 2.5),
        (0.5, 0.5),  # low, but above home: as asked
        (10.0, 10.0),  # takeoff_max_height_m itself is allowed
    ],
)
def test_takeoff_height_is_the_requested_one_above_home_or_the_default(
    requested_m: float, expected_m: float
) -> None:
    bench = Bench()
    bench.command(arm())
    cmd = replace(takeoff(HOME_AMSL_M + requested_m), param4=1.0)
    out = bench.command(cmd)
    assert out.acks[0].result is CommandResult.ACCEPTED
    target = out.status.takeoff_target
    assert target is not None
    assert target.height_above_home_m == pytest.approx(expected_m)
    assert target.altitude_amsl_m == pytest.approx(HOME_AMSL_M + expected_m)
    assert target.yaw == 1.0, "NAV_TAKEOFF param4 is the heading"


def test_takeoff_in_the_air_is_relative_to_home_not_to_where_the_vehicle_is() -> None:
    bench = Bench()
    bench.command(arm())
    bench.airborne(4.0)
    bench.run(200 * MS)
    target = bench.command(takeoff()).status.takeoff_target
    assert target is not None
    assert target.altitude_amsl_m == pytest.approx(HOME_AMSL_M + CommanderParams().takeoff_height_m)


def test_takeoff_without_a_known_altitude_counts_from_zero() -> None:
    bench = Bench(altitude_amsl_m=math.nan)
    bench.command(arm())
    default = bench.command(takeoff()).status.takeoff_target
    assert default is not None
    assert default.altitude_amsl_m == default.height_above_home_m == 2.5
    asked = bench.command(takeoff(5.0)).status.takeoff_target
    assert asked is not None
    assert asked.altitude_amsl_m == asked.height_above_home_m == 5.0


def test_takeoff_mode_via_do_set_mode_auto_takeoff() -> None:
    bench = Bench()
    bench.command(arm())
    out = bench.command(set_auto(2))
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.nav_state is NavigationState.AUTO_TAKEOFF


def test_land_then_landed_then_auto_disarm_after_com_disarm_land() -> None:
    bench = Bench()
    bench.command(arm())
    bench.command(takeoff(HOME_AMSL_M + 1.5))
    bench.airborne(1.5)
    bench.run(500 * MS)
    out = bench.command(land())
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert out.status.nav_state is NavigationState.AUTO_LAND
    assert out.status.land_target is not None
    bench.run(1 * S)
    bench.landed = True
    bench.altitude_amsl_m = HOME_AMSL_M
    landed_at = bench.now_us
    outs = bench.run(3 * S)
    disarmed = next(o for o in outs if o.status.arming_state is ArmingState.DISARMED)
    assert disarmed.status.timestamp_us - landed_at == 2 * S
    assert disarmed.status.latest_disarming_reason is ArmDisarmReason.AUTO_DISARM_LAND
    assert disarmed.status.nav_state is not NavigationState.AUTO_LAND
    assert not disarmed.status.failsafe


def test_disarming_ends_the_flight_takeoff_target_landing_target_and_failsafe() -> None:
    bench = Bench()
    bench.command(arm())
    bench.command(takeoff(HOME_AMSL_M + 1.5))
    bench.airborne(1.5)
    bench.run(200 * MS)
    there = replace(land(), param5=45.0, param6=7.0)
    assert bench.command(there).status.land_target is not None
    bench.battery = BatteryWarning.CRITICAL
    out = bench.tick()
    assert out.status.failsafe_reason is FailsafeReason.BATTERY_CRITICAL
    assert out.status.land_target is not None and out.status.land_target.latitude_deg == 45.0
    bench.landed, bench.altitude_amsl_m = True, HOME_AMSL_M
    disarm_at = bench.now_us
    out = bench.command(disarm())
    assert out.status.arming_state is ArmingState.DISARMED
    assert out.status.nav_state_timestamp_us == disarm_at
    assert not out.status.failsafe and out.status.failsafe_reason is FailsafeReason.NONE
    assert out.status.takeoff_target is None
    # next flight: a failsafe landing lands here, not at the last flight's coordinates
    bench.battery = BatteryWarning.LOW
    bench.command(arm())
    bench.airborne()
    bench.run(200 * MS)
    bench.battery = BatteryWarning.CRITICAL
    out = bench.tick()
    assert out.status.nav_state is NavigationState.AUTO_LAND
    assert out.status.land_target is not None
    assert math.isnan(out.status.land_target.latitude_deg)
    assert math.isnan(out.status.land_target.longitude_deg)


def test_nav_land_lands_at_its_coordinates_and_heading() -> None:
    bench = Bench()
    bench.command(arm())
    bench.airborne()
    bench.run(200 * MS)
    out = bench.command(replace(land(), param4=0.5, param5=45.0, param6=7.0))
    assert out.status.land_target is not None
    target = out.status.land_target
    assert (target.latitude_deg, target.longitude_deg, target.yaw) == (45.0, 7.0, 0.5)


def test_acks_echo_the_command_and_name_every_failed_check() -> None:
    bench = Bench(position_valid=False, attitude_valid=False)
    internal = replace(arm(), from_external=False, source_system=9, source_component=3)
    at = bench.now_us
    ack = bench.command(internal).acks[0]
    assert (ack.timestamp_us, ack.command, ack.from_external) == (at, 400, False)
    assert (ack.target_system, ack.target_component) == (9, 3)
    assert ack.result_param1 == DenyReason.ATTITUDE_INVALID
    assert ack.reason == "; ".join(
        r.text for r in (DenyReason.ATTITUDE_INVALID, DenyReason.POSITION_INVALID)
    )
    bench.position_valid = bench.attitude_valid = True
    out = bench.command(internal)
    assert out.acks[0].result is CommandResult.ACCEPTED
    assert (out.acks[0].result_param1, out.acks[0].reason) == (0, "")
    assert out.status.latest_arming_reason is ArmDisarmReason.COMMAND_INTERNAL
    assert out.status.nav_state_timestamp_us == bench.now_us - TICK_US
    assert out.status.armed_time_us == bench.now_us - TICK_US


def test_the_takeoff_target_is_reported_until_disarmed() -> None:
    bench = Bench()
    bench.command(arm())
    target = bench.command(takeoff(HOME_AMSL_M + 1.5)).status.takeoff_target
    assert target is not None
    bench.airborne(1.5)
    assert bench.tick().status.nav_state is NavigationState.AUTO_LOITER  # takeoff done
    out = bench.command(set_auto(3))
    assert out.status.takeoff_target == target


def test_armed_on_the_ground_without_taking_off_disarms_after_com_disarm_prflt() -> None:
    bench = Bench()
    armed_at = bench.now_us
    bench.command(arm())
    outs = bench.run(12 * S)
    disarmed = next(o for o in outs if o.status.arming_state is ArmingState.DISARMED)
    assert disarmed.status.timestamp_us - armed_at == 10 * S
    assert disarmed.status.latest_disarming_reason is ArmDisarmReason.AUTO_DISARM_PREFLIGHT


def test_each_arming_starts_a_new_flight_for_auto_disarm() -> None:
    """After a flight and a disarm, arming again on the ground waits COM_DISARM_PRFLT."""
    bench = Bench()
    bench.command(arm())
    bench.airborne()
    bench.run(1 * S)
    bench.landed, bench.altitude_amsl_m = True, HOME_AMSL_M
    bench.run(500 * MS)
    assert bench.command(disarm()).status.arming_state is ArmingState.DISARMED
    bench.run(1 * S)
    armed_at = bench.now_us
    bench.command(arm())
    outs = bench.run(12 * S)
    disarmed = next(o for o in outs if o.status.arming_state is ArmingState.DISARMED)
    assert disarmed.status.timestamp_us - armed_at == 10 * S
    assert disarmed.status.latest_disarming_reason is ArmDisarmReason.AUTO_DISARM_PREFLIGHT


def test_takeoff_is_done_exactly_at_the_acceptance_distance() -> None:
    bench = Bench(params=CommanderParams(takeoff_acceptance_m=0.5))
    bench.command(arm())
    bench.command(takeoff(HOME_AMSL_M + 1.5))
    bench.landed, bench.altitude_amsl_m = False, HOME_AMSL_M + 0.75
    assert bench.tick().status.nav_state is NavigationState.AUTO_TAKEOFF
    bench.altitude_amsl_m = HOME_AMSL_M + 1.0  # 1.5 - 0.5
    assert bench.tick().status.nav_state is NavigationState.AUTO_LOITER


def test_disarm_land_s_zero_disarms_on_touchdown() -> None:
    bench = Bench(params=CommanderParams(disarm_land_s=0.0))
    bench.command(arm())
    bench.airborne()
    bench.run(200 * MS)
    bench.landed = True
    out = bench.tick()
    assert out.status.arming_state is ArmingState.DISARMED
    assert out.status.latest_disarming_reason is ArmDisarmReason.AUTO_DISARM_LAND


def test_land_and_rtl_are_refused_while_disarmed() -> None:
    bench = Bench()
    for cmd in (land(), VehicleCommandData(VehicleCmd.NAV_RETURN_TO_LAUNCH)):
        ack = bench.command(cmd).acks[0]
        assert ack.result is CommandResult.DENIED
        assert ack.result_param1 == DenyReason.DISARMED


# -- commands the commander does not handle -------------------------------------------------


@pytest.mark.parametrize(
    ("cmd", "reason"),
    [
        (VehicleCommandData(34), DenyReason.UNSUPPORTED_COMMAND),  # DO_ORBIT
        (VehicleCommandData(300), DenyReason.UNSUPPORTED_COMMAND),  # MISSION_START
        (VehicleCommandData(176, param1=1.0, param2=3.0), DenyReason.UNSUPPORTED_MODE),  # POSCTL
        (VehicleCommandData(176, param1=1.0, param2=4.0, param3=4.0), DenyReason.UNSUPPORTED_MODE),
        (VehicleCommandData(176, param1=0.0, param2=6.0), DenyReason.UNSUPPORTED_MODE),
    ],
)
def test_unsupported_commands_are_acknowledged_unsupported(
    cmd: VehicleCommandData, reason: DenyReason
) -> None:
    out = Bench().command(replace(cmd, source_system=255, source_component=190))
    ack = out.acks[0]
    assert ack.result is CommandResult.UNSUPPORTED
    assert ack.result_param1 == reason
    assert ack.command == cmd.command
    assert (ack.target_system, ack.target_component) == (255, 190), "ack goes to the sender"


def test_commands_for_another_system_or_component_are_ignored() -> None:
    bench = Bench()
    out = bench.tick(replace(arm(), target_system=2), replace(arm(), target_component=5))
    assert out.acks == ()
    assert out.status.arming_state is ArmingState.DISARMED
    assert bench.tick(replace(arm(), target_system=0)).acks[0].result is CommandResult.ACCEPTED


# -- battery --------------------------------------------------------------------------------


def test_battery_low_in_flight_only_warns() -> None:
    bench = armed_in_offboard()
    bench.battery = BatteryWarning.LOW
    out = bench.run(1 * S)[-1]
    assert out.status.nav_state is NavigationState.OFFBOARD
    assert not out.status.failsafe
    assert out.status.battery_warning is BatteryWarning.LOW


def test_battery_critical_in_flight_lands() -> None:
    bench = armed_in_offboard()
    bench.battery = BatteryWarning.CRITICAL
    out = bench.tick()
    assert out.status.nav_state is NavigationState.AUTO_LAND
    assert out.status.failsafe
    assert out.status.failsafe_reason is FailsafeReason.BATTERY_CRITICAL


def test_battery_critical_returns_with_action_return_and_emergency_then_lands() -> None:
    bench = armed_in_offboard(CommanderParams(low_battery_action=BatteryFailsafeAction.RETURN))
    bench.battery = BatteryWarning.CRITICAL
    assert bench.tick().status.nav_state is NavigationState.AUTO_RTL
    bench.battery = BatteryWarning.EMERGENCY
    out = bench.tick()
    assert out.status.nav_state is NavigationState.AUTO_LAND
    assert out.status.failsafe_reason is FailsafeReason.BATTERY_EMERGENCY


def test_the_battery_failsafe_acts_once_per_level_so_the_pilot_can_take_over() -> None:
    bench = armed_in_offboard(CommanderParams(low_battery_action=BatteryFailsafeAction.RETURN))
    bench.battery = BatteryWarning.CRITICAL
    assert bench.tick().status.nav_state is NavigationState.AUTO_RTL
    takeover = bench.command(set_auto(3))  # loiter: allowed below EMERGENCY
    assert takeover.acks[0].result is CommandResult.ACCEPTED
    outs = bench.run(2 * S)
    loitering = [o.status.nav_state is NavigationState.AUTO_LOITER for o in outs]
    assert all(loitering), "the CRITICAL failsafe acted twice"
    assert not outs[-1].status.failsafe
    bench.battery = BatteryWarning.EMERGENCY  # a new level acts, once
    assert bench.tick().status.nav_state is NavigationState.AUTO_LAND


def test_the_battery_failsafe_acts_again_after_a_new_arming() -> None:
    bench = armed_in_offboard()
    bench.battery = BatteryWarning.CRITICAL
    assert bench.tick().status.nav_state is NavigationState.AUTO_LAND
    bench.landed = True
    bench.altitude_amsl_m = HOME_AMSL_M
    assert bench.command(disarm()).status.arming_state is ArmingState.DISARMED
    bench.battery = BatteryWarning.LOW  # recovered (a fresh pack), then armed again
    assert bench.command(arm()).status.nav_state is NavigationState.AUTO_LOITER
    bench.airborne()
    bench.run(200 * MS)
    bench.battery = BatteryWarning.CRITICAL
    out = bench.tick()
    assert out.status.nav_state is NavigationState.AUTO_LAND
    assert out.status.failsafe_reason is FailsafeReason.BATTERY_CRITICAL


def test_battery_emergency_refuses_every_mode_but_land() -> None:
    bench = armed_in_offboard()
    bench.battery = BatteryWarning.EMERGENCY
    assert bench.tick().status.nav_state is NavigationState.AUTO_LAND
    for cmd in (set_offboard(), set_auto(3), takeoff()):
        ack = bench.command(cmd).acks[0]
        assert ack.result is CommandResult.TEMPORARILY_REJECTED
        assert ack.result_param1 == DenyReason.BATTERY_EMERGENCY
    assert bench.command(land()).acks[0].result is CommandResult.ACCEPTED


def test_battery_action_warning_never_changes_mode() -> None:
    bench = armed_in_offboard(CommanderParams(low_battery_action=BatteryFailsafeAction.WARNING))
    bench.battery = BatteryWarning.EMERGENCY
    assert bench.run(1 * S)[-1].status.nav_state is NavigationState.OFFBOARD


# -- the table ------------------------------------------------------------------------------


def test_every_state_has_a_reaction_to_every_event() -> None:
    missing = [(s, e) for s in FlightState for e in Event if (s, e) not in TRANSITIONS]
    assert not missing, f"no row for {missing}"
    assert len(TRANSITIONS) == len(FlightState) * len(Event)


def test_the_module_docstring_shows_the_table_as_it_is() -> None:
    assert commander_module.__doc__ is not None
    assert render_transition_table() in commander_module.__doc__, (
        "the table in the docstring is stale: paste render_transition_table()"
    )


def test_no_row_leads_a_disarmed_vehicle_into_a_mode_and_only_arm_leaves_disarmed() -> None:
    for (state, event), row in TRANSITIONS.items():
        if state is FlightState.DISARMED:
            assert row.target is None or row.action.value == "remember", (event, row)
        if row.target is FlightState.DISARMED:
            assert event in (Event.DISARM, Event.AUTO_DISARM), (state, event)


_COMMANDS = st.sampled_from(
    [
        arm(),
        arm(force=True),
        disarm(),
        disarm(force=True),
        set_offboard(),
        set_auto(2),
        set_auto(3),
        set_auto(5),
        set_auto(6),
        set_auto(4),
        takeoff(),
        takeoff(HOME_AMSL_M + 1.0),
        takeoff(HOME_AMSL_M + 99.0),
        land(),
        VehicleCommandData(VehicleCmd.NAV_RETURN_TO_LAUNCH),
        VehicleCommandData(34),
        VehicleCommandData(400, param1=math.nan),
        replace(arm(), target_system=7),
    ]
)


@st.composite
def _ticks(draw: st.DrawFn) -> list[tuple[int, CommanderInputs]]:
    now = 0
    heartbeat: int | None = None
    ticks = []
    for _ in range(draw(st.integers(1, 60))):
        now += draw(st.sampled_from([1 * MS, 20 * MS, 100 * MS, 400 * MS, 1500 * MS]))
        if draw(st.booleans()):
            heartbeat = now - draw(st.integers(0, 50 * MS))
        ticks.append(
            (
                now,
                CommanderInputs(
                    now_us=now,
                    offboard_heartbeat_us=heartbeat,
                    landed=draw(st.booleans()),
                    battery_warning=draw(st.sampled_from(list(BatteryWarning))),
                    attitude_valid=draw(st.booleans()),
                    position_valid=draw(st.booleans()),
                    altitude_amsl_m=draw(st.one_of(st.floats(90.0, 120.0), st.just(math.nan))),
                    commands=tuple(draw(st.lists(_COMMANDS, max_size=3))),
                ),
            )
        )
    return ticks


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(ticks=_ticks())
def test_random_command_sequences_keep_the_invariants(
    ticks: list[tuple[int, CommanderInputs]],
) -> None:
    commander = Commander(CommanderParams(failsafe_hold_s=0.5, disarm_preflight_s=3.0))
    previous = FlightState.DISARMED
    for _, inputs in ticks:
        out = commander.step(inputs)
        status = out.status
        addressed = [c for c in inputs.commands if c.target_system in (0, 1)]
        assert len(out.acks) == len(addressed), "one ack per command for this vehicle"
        assert all(isinstance(a.result, CommandResult) for a in out.acks)
        armed = status.arming_state is ArmingState.ARMED
        assert armed == status.state.armed
        if not armed:
            assert status.nav_state is not NavigationState.OFFBOARD, "disarmed implies not OFFBOARD"
            assert not status.failsafe
        assert status.nav_state is status.state.nav_state
        if status.state is FlightState.OFFBOARD and previous is not FlightState.OFFBOARD:
            assert status.offboard_signal_established, "OFFBOARD entered without the signal"
        if not previous.armed and armed:
            forced = any(
                c.command == VehicleCmd.COMPONENT_ARM_DISARM and c.param2 == FORCE_ARM_DISARM_MAGIC
                for c in inputs.commands
            )
            assert forced or inputs.landed, "armed in the air without force"
        previous = status.state


# -- parameters -----------------------------------------------------------------------------


def test_the_config_file_loads_and_matches_the_code_defaults() -> None:
    params = load_parameters(CommanderParams, COMMANDER_NODE_NAME)
    assert params == CommanderParams(), "the code defaults and fcu_commander.yaml disagree"
    assert params.offboard_loss_timeout_s == 1.0
    assert params.disarm_land_s == 2.0
    assert params.offboard_loss_action is OffboardLossAction.LAND


EKF2_NOAID_TOUT_US = 5_000_000  # PX4's default: dead reckoning allowed after the last aiding


def test_the_position_loss_failsafe_comes_ekf2_noaid_tout_after_the_last_vision_sample() -> None:
    """PX4 dead-reckons for EKF2_NOAID_TOUT before its commander fails over at once; ours
    calls the position invalid sooner (the estimator's vision timeout) and waits the rest
    in the commander. The two files must keep adding up to PX4's total."""
    commander = load_parameters(CommanderParams, COMMANDER_NODE_NAME)
    estimator = load_parameters(EstimatorParams, ESTIMATOR_NODE_NAME)
    total_us = estimator.vision_timeout_us + round(commander.position_loss_delay_s * S)
    assert total_us == EKF2_NOAID_TOUT_US, (
        f"vision_timeout_us + position_loss_delay_s = {total_us} us, PX4 has 5 s")
    # and the estimator dead-reckons on the gyro as long (EKF2's own timeout)
    assert estimator.noaid_timeout_us == EKF2_NOAID_TOUT_US


def test_takeoff_max_height_may_equal_the_default_height_but_not_be_below() -> None:
    CommanderParams(takeoff_height_m=5.0, takeoff_max_height_m=5.0)  # allowed: no error
    too_low = r"takeoff_max_height_m: 4\.0 is outside.*\[takeoff_height_m = 5\.0, "
    with pytest.raises(ParameterError, match=too_low):
        CommanderParams(takeoff_height_m=5.0, takeoff_max_height_m=4.0)


def test_parameter_errors_name_the_key_and_the_range() -> None:
    with pytest.raises(ParameterError, match=r"fcu_commander\.bogus"):
        parameters_from_mapping(CommanderParams, COMMANDER_NODE_NAME,
                                {"fcu_commander": {"ros__parameters": {"bogus": 1}}})
    with pytest.raises(ParameterError, match=r"disarm_land_s.*\[-1, 20\] s"):
        parameters_from_mapping(CommanderParams, COMMANDER_NODE_NAME,
            {"fcu_commander": {"ros__parameters": {"disarm_land_s": 99.0}}}
        )
    with pytest.raises(ParameterError, match=r"offboard_loss_action.*hold, land, return"):
        parameters_from_yaml(CommanderParams, COMMANDER_NODE_NAME,
            "fcu_commander:\n  ros__parameters:\n    offboard_loss_action: explode\n"
        )
    with pytest.raises(ParameterError, match=r"failsafe_hold_s.*must be a number"):
        CommanderParams(failsafe_hold_s="5")  # type: ignore[arg-type]


# -- position loss ----------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["offboard", "hold", "land"])
def test_position_loss_descends_after_com_pos_fs_delay_without_a_hold(mode: str) -> None:
    """PX4's mode fallback: the mode needs a position, RTL and Land too, so Descend, at
    once after the delay (Hold cannot run, so no COM_FAIL_ACT_T hold first)."""
    bench = armed_in_offboard(CommanderParams(position_loss_delay_s=1.0, failsafe_hold_s=5.0))
    if mode != "offboard":
        out = bench.command(set_auto(3) if mode == "hold" else land())
        assert out.acks[0].result is CommandResult.ACCEPTED
    lost_at = bench.now_us
    bench.position_valid = False
    outs = bench.run(3 * S)
    states = [o.status.nav_state for o in outs]
    assert NavigationState.AUTO_LOITER not in states[1:] or mode == "hold"
    descend = next(o for o in outs if o.status.nav_state is NavigationState.DESCEND)
    assert 1 * S <= descend.status.timestamp_us - lost_at <= 1 * S + TICK_US
    assert descend.status.failsafe
    assert descend.status.failsafe_reason is FailsafeReason.POSITION_LOSS
    assert set(states[states.index(NavigationState.DESCEND):]) == {NavigationState.DESCEND}


def test_a_position_loss_shorter_than_the_delay_changes_nothing() -> None:
    bench = armed_in_offboard(CommanderParams(position_loss_delay_s=1.0))
    bench.position_valid = False
    outs = bench.run(1 * S - TICK_US)
    bench.position_valid = True
    outs += bench.run(2 * S)
    assert {o.status.nav_state for o in outs} == {NavigationState.OFFBOARD}
    assert not any(o.status.failsafe for o in outs)


def test_an_eph_worse_than_com_pos_fs_eph_descends_at_once_without_the_delay() -> None:
    """COM_POS_FS_EPH: the estimate's own accuracy says it may be further off than the
    limit, so the position is lost now, whatever the delay or the estimator's flag."""
    bench = armed_in_offboard(CommanderParams(position_loss_delay_s=4.5,
                                              position_loss_eph_m=1.0))
    bench.position_valid = False
    bench.eph_m = 0.9  # dead reckoning, still within the limit: OFFBOARD until the delay
    outs = bench.run(1 * S)
    assert {o.status.nav_state for o in outs} == {NavigationState.OFFBOARD}
    bench.eph_m = 1.01
    out = bench.tick()
    assert out.status.nav_state is NavigationState.DESCEND
    assert out.status.failsafe_reason is FailsafeReason.POSITION_LOSS
    # flagged valid by the estimator but too coarse: lost all the same
    bench2 = armed_in_offboard(CommanderParams(position_loss_eph_m=1.0))
    bench2.eph_m = 1.5
    assert bench2.tick().status.nav_state is NavigationState.DESCEND
    # and back within the limit with the position valid: the descent clears
    bench2.eph_m = 0.05
    assert bench2.tick().status.nav_state is NavigationState.OFFBOARD


def test_the_descent_lands_and_disarms_and_refuses_position_modes() -> None:
    bench = armed_in_offboard(CommanderParams(position_loss_delay_s=0.5, disarm_land_s=2.0))
    bench.position_valid = False
    bench.run(1 * S)
    assert bench.tick().status.nav_state is NavigationState.DESCEND
    refused = bench.command(set_auto(3))
    assert refused.acks[0].result is CommandResult.TEMPORARILY_REJECTED
    assert refused.acks[0].result_param1 == DenyReason.POSITION_INVALID
    bench.battery = BatteryWarning.CRITICAL
    assert bench.tick().status.nav_state is NavigationState.DESCEND, "already landing"
    bench.landed = True
    outs = bench.run(3 * S)
    assert outs[-1].status.arming_state is ArmingState.DISARMED
    assert outs[-1].status.latest_disarming_reason is ArmDisarmReason.AUTO_DISARM_LAND


def test_the_position_back_holds_then_returns_to_offboard_with_its_signal() -> None:
    bench = armed_in_offboard(CommanderParams(position_loss_delay_s=0.5))
    bench.position_valid = False
    bench.run(1 * S)
    assert bench.tick().status.nav_state is NavigationState.DESCEND
    bench.position_valid = True
    out = bench.tick()
    assert out.status.nav_state is NavigationState.OFFBOARD, "the mode the user chose"
    assert not out.status.failsafe
    # without the offboard signal it holds
    bench.position_valid = False
    bench.run(1 * S)
    bench.stream(None)
    bench.run(2 * S)
    assert bench.tick().status.nav_state is NavigationState.DESCEND
    bench.position_valid = True
    out = bench.tick()
    assert out.status.nav_state is NavigationState.AUTO_LOITER
    assert not out.status.failsafe
