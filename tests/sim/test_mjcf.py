"""The compiled scene: models compile, the drone flies as the parameters say, robots move."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from sim.arena import ArenaSpec
from sim.arena_generator import generate_arena
from sim.errors import SimError
from sim.mjcf import DEFAULT_TIMESTEP_US, build_model, pad_geom_name
from sim.quadrotor import GRAVITY, MotorModel, QuadrotorParams, mix
from sim.scene import (
    SceneIndex,
    SceneViews,
    place_quadrotor,
    quad_state,
    read_imu,
    set_motor_thrusts,
    set_robot_poses,
)

PARAMS = QuadrotorParams()


def _fly(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    index: SceneIndex,
    motors: MotorModel,
    command: np.ndarray,
    duration: float,
) -> None:
    """The world loop in miniature: motor lag, then one physics step, ``duration`` seconds."""
    dt = model.opt.timestep
    for _ in range(round(duration / dt)):
        set_motor_thrusts(data, index, motors.step(command, dt))
        mujoco.mj_step(model, data)


def test_default_model_matches_the_parameters(
    model: mujoco.MjModel, index: SceneIndex, arena: ArenaSpec
) -> None:
    assert model.opt.timestep == pytest.approx(DEFAULT_TIMESTEP_US * 1e-6)
    assert model.body_mass[index.quad_body] == pytest.approx(PARAMS.mass)
    np.testing.assert_allclose(model.body_inertia[index.quad_body], PARAMS.inertia)
    np.testing.assert_allclose(model.body_ipos[index.quad_body], 0.0)
    assert model.nmocap == len(arena.robots)
    for pad in arena.pads:
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, pad_geom_name(pad.id)) >= 0
    np.testing.assert_allclose(model.actuator_ctrlrange[list(index.motors)], [[0.0, 9.2]] * 4)


def test_motors_are_one_slice_of_ctrl(index: SceneIndex) -> None:
    """set_motor_thrusts writes the four thrusts through one slice: the index refuses
    motors whose actuator ids are not in a row."""
    assert index.motor_ctrl == slice(index.motors[0], index.motors[0] + 4)
    with pytest.raises(SimError, match=r"actuator ids \(0, 2, 1, 3\) are not 4 in a row"):
        dataclasses.replace(index, motors=(0, 2, 1, 3))


def test_scene_views_read_and_write_the_data(
    model: mujoco.MjModel, data: mujoco.MjData, index: SceneIndex
) -> None:
    """The views the world's parts use are the data itself, at the index's addresses."""
    views = SceneViews.of(data, index)
    state = quad_state(data, index)
    np.testing.assert_array_equal(views.quad_qpos, [*state.position, *state.quaternion])
    np.testing.assert_array_equal(views.quad_qvel, [*state.velocity, *state.angular_velocity])
    views.motor_ctrl[:] = (1.0, 2.0, 3.0, 4.0)
    np.testing.assert_array_equal(data.ctrl[list(index.motors)], [1.0, 2.0, 3.0, 4.0])
    views.quad_force[:] = (0.5, 0.0, -0.5)
    np.testing.assert_array_equal(data.xfrc_applied[index.quad_body], [0.5, 0.0, -0.5, 0, 0, 0])
    mujoco.mj_forward(model, data)
    imu = read_imu(data, index)
    np.testing.assert_array_equal(views.imu, [*imu.accel, *imu.gyro])
    with pytest.raises(SimError, match="does not follow the accelerometer's"):
        dataclasses.replace(index, gyro_adr=index.accel_adr + 4)


@pytest.mark.parametrize("seed", range(20))
def test_random_arenas_compile(seed: int) -> None:
    arena = generate_arena(seed)
    model = build_model(arena)
    index = SceneIndex.from_model(model, arena)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    x, y, z = arena.takeoff_position
    position = quad_state(data, index).position
    np.testing.assert_allclose(position, (x, y, z + PARAMS.leg_height))


def test_drone_rests_on_the_start_pad(
    model: mujoco.MjModel, data: mujoco.MjData, index: SceneIndex
) -> None:
    start = quad_state(data, index).position
    _fly(model, data, index, MotorModel(PARAMS), np.zeros(4), 1.0)
    settled = quad_state(data, index)
    assert np.abs(settled.position - start).max() < 2e-3, "stands on its legs, does not sink"
    np.testing.assert_allclose(read_imu(data, index).accel, [0, 0, GRAVITY], atol=1e-3)


def test_free_fall_follows_gravity(
    model: mujoco.MjModel, data: mujoco.MjData, index: SceneIndex
) -> None:
    place_quadrotor(model, data, index, (3.0, 5.0, 3.0))
    _fly(model, data, index, MotorModel(PARAMS), np.zeros(4), 0.5)
    state = quad_state(data, index)
    assert state.position[2] == pytest.approx(3.0 - 0.5 * GRAVITY * 0.5**2, abs=0.01)
    assert state.velocity[2] == pytest.approx(-GRAVITY * 0.5, abs=1e-6)
    np.testing.assert_allclose(read_imu(data, index).accel, 0.0, atol=1e-6, err_msg="weightless")


def test_open_loop_hover_holds_position_for_10_s(
    model: mujoco.MjModel, data: mujoco.MjData, index: SceneIndex
) -> None:
    start = (3.0, 5.0, 1.5)
    place_quadrotor(model, data, index, start, yaw=0.3)
    motors = MotorModel.hovering(PARAMS)
    _fly(model, data, index, motors, np.full(4, PARAMS.hover_thrust), 10.0)
    state = quad_state(data, index)
    assert data.time == pytest.approx(10.0)
    np.testing.assert_allclose(state.position, start, atol=1e-6)
    np.testing.assert_allclose(state.quaternion, [math.cos(0.15), 0, 0, math.sin(0.15)], atol=1e-9)
    np.testing.assert_allclose(read_imu(data, index).accel, [0, 0, GRAVITY], atol=1e-6)


def test_spin_up_from_rest_lifts_off_with_extra_thrust(
    model: mujoco.MjModel, data: mujoco.MjData, index: SceneIndex
) -> None:
    start = quad_state(data, index).position
    _fly(model, data, index, MotorModel(PARAMS), np.full(4, 1.2 * PARAMS.hover_thrust), 1.0)
    climbed = quad_state(data, index).position - start
    # Thrust 1.2 W (1 - exp(-t / tau)) lifts off at t0 = tau ln 6; integrate twice to t = 1 s.
    tau, t = PARAMS.motor_tau, 1.0
    t0 = tau * math.log(6.0)
    lag = tau * math.exp(-t0 / tau) * (t - t0 - tau) + tau**2 * math.exp(-t / tau)
    expected = GRAVITY * (0.1 * (t - t0) ** 2 - 1.2 * lag)
    assert climbed[2] == pytest.approx(expected, rel=0.02)
    assert np.abs(climbed[:2]).max() < 1e-6, "straight up"


@pytest.mark.parametrize(
    ("torque", "axis"),
    [((0.05, 0, 0), 0), ((0, 0.05, 0), 1), ((0, 0, 0.02), 2)],
    ids=["roll", "pitch", "yaw"],
)
def test_mixer_torques_turn_the_body_the_right_way(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    index: SceneIndex,
    torque: tuple[float, float, float],
    axis: int,
) -> None:
    place_quadrotor(model, data, index, (3.0, 5.0, 2.0))
    command = mix(PARAMS, PARAMS.weight, torque)
    motors = MotorModel(PARAMS, command)  # already at the commanded thrust: no lag transient
    _fly(model, data, index, motors, command, 0.1)
    rate = quad_state(data, index).angular_velocity
    expected = torque[axis] / PARAMS.inertia[axis] * 0.1  # body rate after 0.1 s
    assert rate[axis] == pytest.approx(expected, rel=0.02)
    assert np.abs(np.delete(rate, axis)).max() < 1e-3 * abs(expected)
    mujoco.mj_forward(model, data)  # after mj_step, sensors hold the pre-step state
    np.testing.assert_allclose(read_imu(data, index).gyro, rate, atol=1e-9)


def test_robots_move_along_their_paths(
    model: mujoco.MjModel, data: mujoco.MjData, index: SceneIndex, arena: ArenaSpec
) -> None:
    before = data.mocap_pos.copy()
    set_robot_poses(data, index, arena, 5.0)
    mujoco.mj_forward(model, data)
    for robot, mocap in zip(arena.robots, index.robot_mocap, strict=True):
        moved = np.linalg.norm(data.mocap_pos[mocap][:2] - before[mocap][:2])
        assert moved == pytest.approx(5.0 * robot.speed, rel=1e-6), robot.marker_id
        body = model.body(f"robot_{robot.marker_id}").id
        np.testing.assert_allclose(data.xpos[body], data.mocap_pos[mocap])
