"""PX4-style control cascade: parameters, pieces alone, then closed loop on the rigid body.

Closed-loop flights run the cascade (rate 500 Hz, attitude 250 Hz, position 100 Hz) on the
estimator's output, fed by the noisy IMU of sim.quadrotor and 30 Hz vision poses (1 cm
noise, 50 ms latency), against the 1 kHz RK4 rigid body of sim.fcu.rigid_body. Seeded.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from runtime.errors import ParameterError
from runtime.parameters import config_path, load_parameters, parameters_from_yaml
from sim.fcu.control import (
    CONTROL_NODE_NAME,
    AttitudeController,
    Cascade,
    ControlGains,
    InvalidSetpointError,
    PositionController,
    TrajectorySetpointData,
    VehicleState,
    attitude_from_thrust_vector,
    mix_with_desaturation,
    quat_from_axis_angle,
    quat_multiply,
    quat_to_dcm,
    quat_yaw,
)
from sim.fcu.estimator import ESTIMATOR_NODE_NAME, Estimator, EstimatorParams
from sim.fcu.rigid_body import (
    FlightLog,
    RigidBody,
    SetpointSource,
    VisionModel,
    fly,
    imu_frd,
    q_enu_flu_to_ned_frd,
)
from sim.quadrotor import GRAVITY, QuadrotorParams, allocation_matrix

ALTITUDE = 1.5  # m
HOVER_NED = np.array([0.0, 0.0, -ALTITUDE])
PARAMS = QuadrotorParams()


@pytest.fixture(scope="module")
def gains() -> ControlGains:
    return load_parameters(ControlGains, CONTROL_NODE_NAME)


def flight(
    gains: ControlGains, setpoints: SetpointSource, duration_s: float, seed: int = 1
) -> FlightLog:
    """Start hovering at 1.5 m facing North; estimator in the loop, 50 ms vision latency,
    its gyro bias calibrated at rest as the firmware's is before arming."""
    body = RigidBody(
        PARAMS, position_enu=(0.0, 0.0, ALTITUDE), yaw_enu=math.pi / 2,
        rng=np.random.default_rng(seed),
    )  # fmt: skip
    estimator = Estimator(load_parameters(EstimatorParams, ESTIMATOR_NODE_NAME),
                          position_ned=HOVER_NED)
    estimator.set_gyro_bias(gyro_at_rest(body))
    return fly(
        body, Cascade(gains, PARAMS), setpoints, round(duration_s * 1e6),
        estimator=estimator, vision=VisionModel(latency_us=50_000, seed=seed),
    )  # fmt: skip


def gyro_at_rest(body: RigidBody, seconds: float = 2.0, rate_hz: float = 500.0) -> np.ndarray:
    """The gyro's mean [rad/s, FRD] over ``seconds`` with the body still (its rates zero,
    not stepped): what the firmware's calibration at rest (sim/fcu/gyro_calibration.py)
    hands the estimator, noise included."""
    samples = [imu_frd(body.imu(1.0 / rate_hz)).gyro for _ in range(round(seconds * rate_hz))]
    return np.mean(samples, axis=0)


# --- parameters -----------------------------------------------------------------------------


def test_default_config_loads_with_loop_rates_that_divide(gains: ControlGains) -> None:
    assert gains.rate_loop_hz % gains.attitude_loop_hz == 0
    assert gains.rate_loop_hz % gains.position_loop_hz == 0


def _yaml_with(key: str, value: str) -> str:

    lines = config_path("fcu_control.yaml").read_text(encoding="utf-8").splitlines()
    out = [f"    {key}: {value}" if line.strip().startswith(f"{key}:") else line for line in lines]
    return "\n".join(out)


def test_out_of_range_gain_names_the_key_and_the_range() -> None:
    with pytest.raises(ParameterError) as info:
        parameters_from_yaml(ControlGains, CONTROL_NODE_NAME, _yaml_with("max_tilt", "2.0"),
                             "fcu_control.yaml")
    message = str(info.value)
    assert "fcu_control.max_tilt" in message
    assert "[0.05, 1.5] rad" in message and "fcu_control.yaml" in message


def test_unknown_and_missing_keys_are_named() -> None:
    with pytest.raises(ParameterError, match=r"max_tilt_deg: unknown key"):
        parameters_from_yaml(ControlGains, CONTROL_NODE_NAME,
                             _yaml_with("max_tilt", "0.6\n    max_tilt_deg: 30"))
    text = "\n".join(
        line for line in _yaml_with("max_tilt", "0.6").splitlines() if "rate_p_yaw" not in line
    )
    with pytest.raises(ParameterError, match=r"rate_p_yaw: missing"):
        parameters_from_yaml(ControlGains, CONTROL_NODE_NAME, text)


def test_loop_rate_that_does_not_divide_the_rate_loop_is_rejected(gains: ControlGains) -> None:
    with pytest.raises(ParameterError, match=r"position_loop_hz.*must divide"):
        dataclasses.replace(gains, position_loop_hz=75)


def test_integer_parameter_rejects_a_float() -> None:
    with pytest.raises(ParameterError, match=r"rate_loop_hz.*integer"):
        parameters_from_yaml(ControlGains, CONTROL_NODE_NAME, _yaml_with("rate_loop_hz", "500.5"))


# --- frames and pieces ----------------------------------------------------------------------


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_enu_flu_to_ned_frd_quaternion_matches_the_frame_matrices(rv: list[float]) -> None:
    q_enu_flu = quat_from_axis_angle(np.array(rv))
    ned_enu = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    flu_frd = np.diag([1.0, -1.0, -1.0])
    expected = ned_enu @ quat_to_dcm(q_enu_flu) @ flu_frd
    np.testing.assert_allclose(quat_to_dcm(q_enu_flu_to_ned_frd(q_enu_flu)), expected, atol=1e-12)


@settings(max_examples=50, deadline=None)
@given(st.floats(-4.0, 4.0), st.floats(-4.0, 4.0), st.floats(-15.0, -3.0), st.floats(-3.1, 3.1))
def test_attitude_from_thrust_points_minus_body_z_along_thrust_with_the_yaw(
    tx: float, ty: float, tz: float, yaw: float
) -> None:
    thrust = np.array([tx, ty, tz])
    r = quat_to_dcm(attitude_from_thrust_vector(thrust, yaw))
    np.testing.assert_allclose(-r[:, 2], thrust / np.linalg.norm(thrust), atol=1e-9)
    heading = math.atan2(r[1, 0], r[0, 0])  # body x projected on the horizontal plane
    assert abs(math.remainder(heading - yaw, 2 * math.pi)) < 1e-6


def test_attitude_controller_turns_towards_the_setpoint_and_limits_rates(
    gains: ControlGains,
) -> None:
    controller = AttitudeController(gains)
    level = np.array([1.0, 0.0, 0.0, 0.0])
    rolled = quat_from_axis_angle(np.array([0.1, 0.0, 0.0]))
    rate = controller.update(level, rolled)
    assert rate[0] == pytest.approx(0.1 * gains.attitude_p_roll_pitch, rel=0.01)
    assert abs(rate[1]) < 1e-9 and abs(rate[2]) < 1e-9
    big = controller.update(level, quat_from_axis_angle(np.array([0.0, 1.5, 0.0])))
    assert big[1] == pytest.approx(gains.max_rate_roll_pitch)


def test_attitude_controller_deprioritises_yaw(gains: ControlGains) -> None:
    controller = AttitudeController(gains)
    level = np.array([1.0, 0.0, 0.0, 0.0])
    target = quat_multiply(
        quat_from_axis_angle(np.array([0.0, 0.0, 0.2])), quat_from_axis_angle(np.array([0.2, 0, 0]))
    )
    rate = controller.update(level, target)
    # yaw is corrected at the yaw gain, roll/pitch at the (higher) roll/pitch gain
    assert abs(rate[2]) < 0.2 * gains.attitude_p_yaw * 1.05
    assert abs(rate[0]) > 0.19 * gains.attitude_p_roll_pitch


def test_setpoint_with_an_uncontrolled_axis_is_rejected(gains: ControlGains) -> None:
    cascade = Cascade(gains, PARAMS)
    state = VehicleState.at_rest(HOVER_NED)
    bad = TrajectorySetpointData(position=np.array([0.0, 0.0, math.nan]), yaw=0.0)
    with pytest.raises(InvalidSetpointError, match="axis z"):
        cascade.update(state, bad, 2000)
    half = TrajectorySetpointData(
        position=np.array([0.0, math.nan, -1.0]), velocity=np.array([math.nan, 0.0, 0.0])
    )
    with pytest.raises(InvalidSetpointError, match="x and y"):
        cascade.update(state, half, 2000)


def test_hover_command_at_rest_is_hover_thrust_on_every_motor(gains: ControlGains) -> None:
    out = Cascade(gains, PARAMS).update(
        VehicleState.at_rest(HOVER_NED), TrajectorySetpointData.hold_position(HOVER_NED), 2000
    )
    np.testing.assert_allclose(out.motor_thrusts, PARAMS.hover_thrust, rtol=1e-9)
    assert not out.saturated


def test_a_thrust_ceiling_holds_whatever_the_velocity_error_and_stops_the_integrator(
        gains: ControlGains) -> None:
    """DESCEND's ceiling (the firmware's ``descend_acceleration``): on the floor, its
    dead-reckoned velocity saying it falls faster than the land speed, the loop asks to
    brake for 20 s. Without the ceiling its integrator winds up past hover thrust (what
    once lifted a vehicle off the floor into a wall); with it, the thrust never passes
    m (g - a) and the vertical integrator does not grow."""
    descend = TrajectorySetpointData(velocity=np.array([math.nan, math.nan, 0.7]),
                                     acceleration=np.array([0.0, 0.0, math.nan]))
    floor, drifting = (0.0, 0.0, -0.15), (0.0, 0.0, 1.0)  # NED: "falling" at 1 m/s
    level = (1.0, 0.0, 0.0, 0.0)
    ceiling = PARAMS.mass * (GRAVITY - 0.3)

    def thrusts(min_down_acceleration: float) -> tuple[list[float], PositionController]:
        loop = PositionController(gains, PARAMS)
        return [loop.update_floats(floor, drifting, level, descend, 10_000,
                                   min_down_acceleration).collective_thrust
                for _ in range(2000)], loop
    free, _ = thrusts(-math.inf)
    assert max(free) > PARAMS.mass * GRAVITY * 1.1  # it would climb
    capped, loop = thrusts(0.3)
    assert max(capped) <= ceiling * (1 + 1e-9)
    assert loop.velocity_integral[2] == pytest.approx(0.0, abs=1e-9)


@settings(max_examples=200, deadline=None)
@given(
    st.floats(0.0, 60.0),
    st.lists(st.floats(-50.0, 50.0), min_size=3, max_size=3),
)
def test_saturated_mixer_keeps_motors_in_range(collective: float, torque: list[float]) -> None:
    out = mix_with_desaturation(PARAMS, collective, np.array(torque))
    assert np.all(out.motor_thrusts >= 0.0)
    assert np.all(out.motor_thrusts <= PARAMS.max_motor_thrust)


def test_desaturation_gives_up_collective_thrust_before_roll_torque() -> None:
    roll_torque = 1.0  # N m, FRD; about 0.7 m of differential thrust per side
    out = mix_with_desaturation(PARAMS, 35.0, np.array([roll_torque, 0.0, 0.0]))
    wrench = allocation_matrix(PARAMS) @ out.motor_thrusts
    assert wrench[1] == pytest.approx(roll_torque, rel=1e-6)  # FLU x = FRD x
    assert wrench[0] < 35.0 - 1.0  # collective reduced instead
    assert out.collective_thrust == pytest.approx(wrench[0])  # what the rotors produce
    assert not out.saturated_positive[0]


# Rotor thrust [N] per N m of FLU yaw and roll torque: the allocation matrix inverted, by hand
YAW_N_PER_NM = 1.0 / (4 * abs(allocation_matrix(PARAMS)[3, 0]))
ROLL_N_PER_NM = 1.0 / (4 * abs(allocation_matrix(PARAMS)[1, 0]))


def _achieved_frd(motor_thrusts: np.ndarray) -> tuple[float, np.ndarray]:
    """Collective thrust [N] and FRD torque [N m] that the rotors produce."""
    wrench = allocation_matrix(PARAMS) @ motor_thrusts
    return float(wrench[0]), np.array([wrench[1], -wrench[2], -wrench[3]])


def test_airmode_off_never_raises_collective_thrust_to_make_room_for_torque() -> None:
    """At 2 N collective a 0.5 N m roll would need a negative rotor: roll gives way."""
    collective, per_rotor = 2.0, 0.5
    out = mix_with_desaturation(PARAMS, collective, np.array([0.5, 0.0, 0.0]))
    thrust, torque = _achieved_frd(out.motor_thrusts)
    assert thrust == pytest.approx(collective, abs=1e-9), "collective thrust was raised"
    assert out.collective_thrust == pytest.approx(collective, abs=1e-9)
    assert out.motor_thrusts.min() == pytest.approx(0.0, abs=1e-9)
    # roll scaled until the low rotors reach zero: 0.5 N each side of the mean
    assert torque[0] == pytest.approx(per_rotor / ROLL_N_PER_NM, rel=1e-9)
    assert out.saturated_positive.tolist() == [True, False, False]
    assert not out.saturated_negative.any()


def test_yaw_within_15_percent_headroom_is_kept_and_collective_thrust_gives_way() -> None:
    """PX4: yaw may push a rotor 15 % over the top; then thrust comes down to fit."""
    collective = 32.0  # 8 N per rotor, 1.2 N below the 9.2 N top
    top = PARAMS.max_motor_thrust
    over = 0.10 * top  # the yaw demand takes the high rotors 10 % over the top
    yaw_frd = -(top + over - collective / 4) / YAW_N_PER_NM
    out = mix_with_desaturation(PARAMS, collective, np.array([0.0, 0.0, yaw_frd]))
    thrust, torque = _achieved_frd(out.motor_thrusts)
    assert torque[2] == pytest.approx(yaw_frd, rel=1e-9), "yaw gave way within its headroom"
    assert thrust == pytest.approx(collective - 4 * over, rel=1e-9)
    assert out.collective_thrust == pytest.approx(collective - 4 * over, rel=1e-9)
    assert out.motor_thrusts.max() == pytest.approx(top, rel=1e-12)
    assert not (out.saturated_positive.any() or out.saturated_negative.any())


def test_yaw_beyond_the_headroom_is_scaled_to_it_and_flagged() -> None:
    collective, top = 32.0, PARAMS.max_motor_thrust
    out = mix_with_desaturation(PARAMS, collective, np.array([0.0, 0.0, -0.3]))
    thrust, torque = _achieved_frd(out.motor_thrusts)
    kept = (1.15 * top - collective / 4) / YAW_N_PER_NM  # high rotors exactly 15 % over
    assert torque[2] == pytest.approx(-kept, rel=1e-9)
    assert thrust == pytest.approx(collective - 4 * 0.15 * top, rel=1e-9)
    assert out.saturated_negative.tolist() == [False, False, True]
    assert not out.saturated_positive.any()


@pytest.mark.parametrize("collective", [20.0, 42.0])
@pytest.mark.parametrize(("axis", "sign"), [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)])
def test_roll_or_pitch_beyond_authority_spans_the_motor_range_at_half_thrust(
    collective: float, axis: int, sign: float
) -> None:
    """Thrust is centred in the motor range (PX4's two-pass desaturation), then the torque
    takes all of it: two rotors at zero, two at full, whatever collective was asked."""
    torque = np.zeros(3)
    torque[axis] = sign * 10.0  # N m, far beyond the ~2.9 N m available
    out = mix_with_desaturation(PARAMS, collective, torque)
    top = PARAMS.max_motor_thrust
    assert sorted(out.motor_thrusts.tolist()) == pytest.approx([0.0, 0.0, top, top], abs=1e-9)
    thrust, achieved = _achieved_frd(out.motor_thrusts)
    assert thrust == pytest.approx(2 * top) and out.collective_thrust == pytest.approx(2 * top)
    authority = 2 * top * abs(allocation_matrix(PARAMS)[1 + axis, 0])
    assert achieved[axis] == pytest.approx(sign * authority)
    flags = out.saturated_positive if sign > 0 else out.saturated_negative
    assert flags.tolist() == [axis == 0, axis == 1, False]


def test_torque_within_authority_is_met_exactly_without_saturation_flags() -> None:
    torque = np.array([0.1, -0.1, 0.02])
    out = mix_with_desaturation(PARAMS, 15.0, torque)
    thrust, achieved = _achieved_frd(out.motor_thrusts)
    assert thrust == pytest.approx(15.0) and out.collective_thrust == pytest.approx(15.0)
    np.testing.assert_allclose(achieved, torque, atol=1e-12)
    assert not out.saturated_positive.any() and not out.saturated_negative.any()


def test_huge_torque_demand_keeps_motors_in_range_and_flags_saturation() -> None:
    out = mix_with_desaturation(PARAMS, 15.0, np.array([40.0, -40.0, 10.0]))
    assert np.all((out.motor_thrusts >= 0.0) & (out.motor_thrusts <= PARAMS.max_motor_thrust))
    assert out.saturated_positive[0] and out.saturated_negative[1]
    # torques are scaled towards zero, never inverted, and some authority is kept
    achieved = allocation_matrix(PARAMS) @ out.motor_thrusts  # [T, FLU torque]
    roll_frd, pitch_frd = achieved[1], -achieved[2]
    assert roll_frd >= -1e-9 and pitch_frd <= 1e-9
    assert roll_frd - pitch_frd > 1.0


def test_cascade_under_huge_attitude_error_saturates_within_bounds_and_integrator_is_bounded(
    gains: ControlGains,
) -> None:
    cascade = Cascade(gains, PARAMS)
    upside_down = VehicleState(HOVER_NED, np.zeros(3), np.array([0.0, 1.0, 0.0, 0.0]), np.zeros(3))
    for _ in range(200):
        out = cascade.update(upside_down, TrajectorySetpointData.hold_position(HOVER_NED), 2000)
        assert np.all((out.motor_thrusts >= 0.0) & (out.motor_thrusts <= PARAMS.max_motor_thrust))
    assert np.all(np.abs(cascade.rate.integral) <= gains.rate_integral_limit_roll_pitch)
    cascade.reset()
    assert not np.any(cascade.rate.integral) and not np.any(cascade.position.velocity_integral)


# --- closed loop ----------------------------------------------------------------------------


@pytest.mark.slow
def test_hover_holds_within_10_cm_for_10_s(gains: ControlGains) -> None:
    log = flight(gains, lambda _t, _s: TrajectorySetpointData.hold_position(HOVER_NED, 0.0), 10)
    error = np.linalg.norm(log.true_position_ned - HOVER_NED, axis=1)
    assert error.max() < 0.1, f"hover error peaked at {error.max():.3f} m"
    assert np.sqrt(np.mean(error**2)) < 0.03


SIDE_S = 4.0
CORNERS = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0], [0.0, 0.0]])


def square_reference(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 4 m square at 1.5 m, each side a 4 s minimum-jerk (quintic) move, then hold."""
    side = min(int(t // SIDE_S), 4)
    if side == 4:
        return np.array([0.0, 0.0, -ALTITUDE]), np.zeros(3), np.zeros(3)
    s = (t - side * SIDE_S) / SIDE_S
    p = 10 * s**3 - 15 * s**4 + 6 * s**5
    dp = (30 * s**2 - 60 * s**3 + 30 * s**4) / SIDE_S
    ddp = (60 * s - 180 * s**2 + 120 * s**3) / SIDE_S**2
    start, delta = CORNERS[side], CORNERS[side + 1] - CORNERS[side]
    return (
        np.array([*(start + p * delta), -ALTITUDE]),
        np.array([*(dp * delta), 0.0]),
        np.array([*(ddp * delta), 0.0]),
    )


@pytest.mark.slow
def test_square_tracking_rmse_below_10_cm(gains: ControlGains) -> None:
    def setpoints(time_us: int, _state: VehicleState) -> TrajectorySetpointData:
        p, v, a = square_reference(time_us / 1e6)
        return TrajectorySetpointData(position=p, velocity=v, acceleration=a, yaw=0.0)

    log = flight(gains, setpoints, 4 * SIDE_S + 1.0)
    reference = np.array([square_reference(t / 1e6)[0] for t in log.time_us])
    rmse = np.sqrt(np.mean((log.true_position_ned - reference) ** 2, axis=0))
    assert rmse[0] < 0.05 and rmse[1] < 0.05, f"square RMSE x, y = {rmse[:2]} m"
    assert not log.saturated.any()
    reached = np.linalg.norm(log.true_position_ned[:, :2] - [4.0, 4.0], axis=1).min()
    assert reached < 0.1, "the square was not flown"


@pytest.mark.slow
def test_position_step_settles_without_overshoot(gains: ControlGains) -> None:
    target = np.array([1.0, 0.0, -2.0])  # 1 m North and 0.5 m up
    log = flight(gains, lambda _t, _s: TrajectorySetpointData.hold_position(target, 0.0), 4)
    north = log.true_position_ned[:, 0]
    up = -log.true_position_ned[:, 2]
    assert north.max() < 1.0 + 0.05, f"overshoot {north.max() - 1.0:.3f} m North"
    assert up.max() < 2.0 + 0.05, f"overshoot {up.max() - 2.0:.3f} m up"
    settled = np.linalg.norm(log.true_position_ned - target, axis=1) < 0.05
    first_settled = int(np.argmax(settled))
    assert settled[first_settled:].all() and log.time_us[first_settled] < 2_500_000


@pytest.mark.slow
def test_velocity_setpoint_reaches_the_commanded_velocity(gains: ControlGains) -> None:
    command = np.array([1.0, 0.5, 0.0])
    setpoint = TrajectorySetpointData(
        position=np.array([math.nan, math.nan, -ALTITUDE]),
        velocity=np.array([1.0, 0.5, math.nan]),
        yaw=0.0,
    )
    log = flight(gains, lambda _t, _s: setpoint, 4)
    last_second = log.time_us >= 3_000_000
    mean = log.true_velocity_ned[last_second].mean(axis=0)
    assert np.linalg.norm(mean[:2] - command[:2]) < 0.1, f"mean velocity {mean}"
    assert abs(log.true_position_ned[-1, 2] + ALTITUDE) < 0.05


@pytest.mark.slow
def test_yaw_setpoint_is_followed(gains: ControlGains) -> None:
    setpoint = TrajectorySetpointData.hold_position(HOVER_NED, yaw=1.0)
    log = flight(gains, lambda _t, _s: setpoint, 2)
    assert abs(quat_yaw(log.true_q[-1]) - 1.0) < 0.05
    assert np.linalg.norm(log.true_position_ned[-1] - HOVER_NED) < 0.1
