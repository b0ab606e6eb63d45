"""Quadrotor constants, mixer, motor lag and IMU noise (pure, no MuJoCo)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from runtime.errors import ParameterError
from sim.quadrotor import (
    GRAVITY,
    ImuNoiseModel,
    ImuNoiseParams,
    ImuSample,
    MotorModel,
    QuadrotorParams,
    Spin,
    allocation_matrix,
    mix,
    rotors,
)

PARAMS = QuadrotorParams()


def test_default_params_are_a_contest_drone() -> None:
    assert PARAMS.mass == pytest.approx(1.5)
    assert PARAMS.thrust_to_weight == pytest.approx(2.5, abs=0.01)
    assert PARAMS.hover_thrust == pytest.approx(1.5 * GRAVITY / 4)
    assert PARAMS.motor_tau == pytest.approx(0.03)
    assert (PARAMS.down_camera.width, PARAMS.down_camera.height) == (640, 480)


def test_x_layout_has_diagonal_pairs_spinning_alike() -> None:
    layout = rotors(PARAMS)
    for first, second in ((0, 1), (2, 3)):
        a, b = layout[first], layout[second]
        assert a.spin == b.spin
        assert a.position[:2] == pytest.approx((-b.position[0], -b.position[1])), "diagonal"
    assert [r.spin for r in layout] == [Spin.CCW, Spin.CCW, Spin.CW, Spin.CW]
    for rotor in layout:
        assert math.hypot(*rotor.position[:2]) == pytest.approx(PARAMS.arm_length)


def test_hover_mix_is_equal_thrust() -> None:
    np.testing.assert_allclose(mix(PARAMS, PARAMS.weight, [0, 0, 0]), [PARAMS.hover_thrust] * 4)


@given(
    st.floats(0.0, 40.0),
    st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3),
)
def test_mixer_inverts_the_allocation(thrust: float, torque: list[float]) -> None:
    motors = mix(PARAMS, thrust, torque)
    np.testing.assert_allclose(allocation_matrix(PARAMS) @ motors, [thrust, *torque], atol=1e-9)


def test_torques_go_to_the_expected_rotors() -> None:
    base = mix(PARAMS, PARAMS.weight, [0, 0, 0])
    roll = mix(PARAMS, PARAMS.weight, [0.5, 0, 0]) - base  # left side up (FLU)
    assert roll[[1, 2]].min() > 0 > roll[[0, 3]].max(), "left rotors push harder"
    pitch = mix(PARAMS, PARAMS.weight, [0, 0.5, 0]) - base  # nose down
    assert pitch[[1, 3]].min() > 0 > pitch[[0, 2]].max(), "rear rotors push harder"
    yaw = mix(PARAMS, PARAMS.weight, [0, 0, 0.1]) - base  # turn left (CCW from above)
    assert yaw[[2, 3]].min() > 0 > yaw[[0, 1]].max(), "clockwise rotors push harder"


def test_motor_lag_is_first_order_with_tau() -> None:
    motors = MotorModel(PARAMS)
    target = np.full(4, 6.0)
    after_tau = motors.step(target, PARAMS.motor_tau)
    np.testing.assert_allclose(after_tau, 6.0 * (1 - math.exp(-1)))
    fine = MotorModel(PARAMS)
    for _ in range(300):
        fine.step(target, PARAMS.motor_tau / 300)
    np.testing.assert_allclose(fine.thrust, after_tau, rtol=1e-12, err_msg="exact in any dt")
    for _ in range(100):
        motors.step(target, 0.01)
    np.testing.assert_allclose(motors.thrust, target, rtol=1e-9)


def test_motor_commands_are_clipped_to_the_motor_range() -> None:
    motors = MotorModel.hovering(PARAMS)
    for _ in range(50):
        motors.step([100.0, -5.0, PARAMS.hover_thrust, 0.0], 0.01)
    np.testing.assert_allclose(
        motors.thrust, [PARAMS.max_motor_thrust, 0.0, PARAMS.hover_thrust, 0.0], atol=1e-6
    )
    assert motors.rotor_speed[0] == pytest.approx(PARAMS.max_rotor_speed)


def test_motor_step_values_are_step_as_floats() -> None:
    arrays, floats = MotorModel(PARAMS), MotorModel(PARAMS)
    for command, dt in (([9.0, 1.0, -1.0, 4.0], 0.002), ([3.0] * 4, 0.002), (5.0, 0.004)):
        want = arrays.step(command, dt)
        got = floats.step_values(command, dt)
        assert isinstance(got, tuple) and list(got) == want.tolist()
    with pytest.raises(ValueError, match="must be >= 0"):
        floats.step_values(1.0, -0.001)


def test_motor_clip_keeps_nan_and_takes_a_scalar() -> None:
    motors = MotorModel(PARAMS, [-1.0, 20.0, math.nan, 3.0])
    np.testing.assert_array_equal(motors.thrust, [0.0, PARAMS.max_motor_thrust, math.nan, 3.0])
    motors.reset(-math.inf)
    np.testing.assert_array_equal(motors.thrust, np.zeros(4))
    assert motors.step(np.float32(4.5), 0.0).tolist() == [0.0] * 4, "dt 0: no change yet"


def test_imu_noise_matches_its_densities_and_is_seeded() -> None:
    params = ImuNoiseParams(
        accel_noise_density=2e-3,
        accel_bias_random_walk=0.0,
        accel_bias_initial_std=0.0,
        gyro_noise_density=1e-4,
        gyro_bias_random_walk=0.0,
        gyro_bias_initial_std=0.0,
    )
    dt = 0.002
    first = ImuNoiseModel(params, np.random.default_rng(5))
    samples = [first.sample([0, 0, GRAVITY], [0, 0, 0], dt) for _ in range(20000)]
    accel = np.array([s.accel for s in samples])
    gyro = np.array([s.gyro for s in samples])
    assert accel.std(axis=0) == pytest.approx([2e-3 / math.sqrt(dt)] * 3, rel=0.03)
    assert gyro.std(axis=0) == pytest.approx([1e-4 / math.sqrt(dt)] * 3, rel=0.03)
    assert accel.mean(axis=0) == pytest.approx([0, 0, GRAVITY], abs=1e-3)
    again = ImuNoiseModel(params, np.random.default_rng(5)).sample([0, 0, GRAVITY], [0, 0, 0], dt)
    np.testing.assert_array_equal(again.accel, samples[0].accel)


def test_imu_sample_is_the_four_normal_draws_it_replaced() -> None:
    """One draw of 12 standard normals gives bit for bit what the former four
    ``rng.normal(0, std, 3)`` calls gave: bias walks (accel, gyro), then white noise."""
    p = ImuNoiseParams()
    model = ImuNoiseModel(p, np.random.default_rng(3))
    rng = np.random.default_rng(3)
    accel_bias = rng.normal(0.0, p.accel_bias_initial_std, 3)
    gyro_bias = rng.normal(0.0, p.gyro_bias_initial_std, 3)
    truth_a, truth_g = np.array([0.1, -0.2, 9.7]), np.array([0.01, 0.0, -0.03])
    for dt in (0.002, 0.002, 0.004):
        accel_bias = accel_bias + rng.normal(0.0, p.accel_bias_random_walk, 3) * math.sqrt(dt)
        gyro_bias = gyro_bias + rng.normal(0.0, p.gyro_bias_random_walk, 3) * math.sqrt(dt)
        white = 1.0 / math.sqrt(dt)
        want_a = truth_a + accel_bias + rng.normal(0.0, p.accel_noise_density * white, 3)
        want_g = truth_g + gyro_bias + rng.normal(0.0, p.gyro_noise_density * white, 3)
        got = model.sample(truth_a, truth_g, dt)
        np.testing.assert_array_equal(got.accel, want_a)
        np.testing.assert_array_equal(got.gyro, want_g)
    np.testing.assert_array_equal(model.accel_bias, accel_bias)


def test_imu_block_draws_give_the_one_sample_at_a_time_noise() -> None:
    """Drawing the normals of several samples at once changes nothing, across block
    boundaries and with the period changing from sample to sample: the reference draws
    12 normals per sample and works on numpy vectors, as the model once did."""
    p = ImuNoiseParams()
    rng = np.random.default_rng(7)
    accel_bias = rng.normal(0.0, p.accel_bias_initial_std, 3)
    gyro_bias = rng.normal(0.0, p.gyro_bias_initial_std, 3)
    walks = np.repeat([p.accel_bias_random_walk, p.gyro_bias_random_walk], 3)
    densities = np.repeat([p.accel_noise_density, p.gyro_noise_density], 3)
    models = [ImuNoiseModel(p, np.random.default_rng(7), block=block) for block in (1, 3, 512)]
    truth_a, truth_g = np.array([0.3, -0.1, 9.9]), np.array([-0.02, 0.05, 0.01])
    for k, dt in enumerate([0.002, 0.004, 0.001, 0.002, 0.0025, 0.002, 0.01, 0.002]):
        z = rng.standard_normal(12)
        sqrt_dt = math.sqrt(dt)
        accel_bias = accel_bias + z[0:3] * walks[0:3] * sqrt_dt
        gyro_bias = gyro_bias + z[3:6] * walks[3:6] * sqrt_dt
        white = z[6:12] * (densities * (1.0 / sqrt_dt))
        want_a = truth_a + accel_bias + white[0:3]
        want_g = truth_g + gyro_bias + white[3:6]
        for model in models:
            got = model.sample(truth_a, truth_g, dt)
            np.testing.assert_array_equal(got.accel, want_a, err_msg=f"sample {k}")
            np.testing.assert_array_equal(got.gyro, want_g, err_msg=f"sample {k}")
            np.testing.assert_array_equal(model.gyro_bias, gyro_bias, err_msg=f"sample {k}")


def test_imu_noisy_values_is_sample_on_floats() -> None:
    """The float path the world's IMU takes gives what ``sample`` gives, bit for bit."""
    truth_a, truth_g = [0.3, -0.1, 9.9], [-0.02, 0.05, 0.01]
    arrays = ImuNoiseModel(ImuNoiseParams(), np.random.default_rng(9), block=2)
    floats = ImuNoiseModel(ImuNoiseParams(), np.random.default_rng(9), block=2)
    for dt in (0.002, 0.002, 0.004, 0.002, 0.002):
        want = arrays.sample(truth_a, truth_g, dt)
        got = floats.noisy_values((*truth_a, *truth_g), dt)
        assert all(type(v) is float for v in got)
        assert got == (*want.accel.tolist(), *want.gyro.tolist())
        sample = ImuSample.of(got)
        np.testing.assert_array_equal(sample.accel, want.accel)
        np.testing.assert_array_equal(sample.gyro, want.gyro)
    with pytest.raises(ValueError, match="must be > 0"):
        floats.noisy_values((0.0,) * 6, 0.0)


def test_a_refused_period_draws_nothing() -> None:
    """A period <= 0 is refused before anything is drawn, at a block's end too."""
    truth = (0.3, -0.1, 9.9, -0.02, 0.05, 0.01)
    model = ImuNoiseModel(ImuNoiseParams(), np.random.default_rng(2), block=2)
    reference = ImuNoiseModel(ImuNoiseParams(), np.random.default_rng(2), block=2)
    for _ in range(2):  # the first block used up
        assert model.noisy_values(truth, 0.002) == reference.noisy_values(truth, 0.002)
    with pytest.raises(ValueError, match="must be > 0"):
        model.noisy_values(truth, -0.002)
    assert model.noisy_values(truth, 0.002) == reference.noisy_values(truth, 0.002)


def test_imu_bias_wanders_and_noiseless_is_truth() -> None:
    biased = ImuNoiseModel(ImuNoiseParams(), np.random.default_rng(1))
    start = biased.gyro_bias
    assert np.abs(start).max() > 0.0
    for _ in range(1000):
        biased.sample([0, 0, 0], [0, 0, 0], 0.01)
    assert not np.array_equal(biased.gyro_bias, start), "random walk"
    exact = ImuNoiseModel(ImuNoiseParams.noiseless(), np.random.default_rng(1))
    sample = exact.sample([0.1, 0.2, 9.8], [0.01, 0.02, 0.03], 0.004)
    np.testing.assert_array_equal(sample.accel, [0.1, 0.2, 9.8])
    np.testing.assert_array_equal(sample.gyro, [0.01, 0.02, 0.03])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"mass": -1.0}, "QuadrotorParams.mass"),
        ({"max_motor_thrust": 3.0}, "thrust to weight 0.82"),
        ({"inertia": (0.01, 0.01, 0.05)}, "QuadrotorParams.inertia"),
        ({"rotor_radius": 0.2}, "QuadrotorParams.rotor_radius"),
    ],
)
def test_bad_params_name_the_field(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ParameterError, match=message):
        QuadrotorParams(**kwargs)  # type: ignore[arg-type]
