"""Reading and writing a compiled scene: ids resolved once, plus the world loop's setters.

:class:`SceneIndex` resolves the names :mod:`sim.mjcf` gives (quad body, joint, motors,
IMU sensors, cameras, robot mocap bodies) to ids and addresses; the functions below use
it to pose the quadrotor, apply rotor thrusts, move the robots and read the IMU truth.
World frame ENU (z up); quaternions are MuJoCo's ``(w, x, y, z)``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from sim.arena import ArenaSpec, StraightDrive, robot_pose
from sim.errors import SimError
from sim.mjcf import (
    ACCEL_SENSOR,
    DEPTH_CAMERA,
    DOWN_CAMERA,
    GYRO_SENSOR,
    QUAD_BODY,
    QUAD_JOINT,
    TOP_CAMERA,
    motor_name,
    robot_body_name,
)
from sim.quadrotor import NUM_ROTORS, ImuSample

FloatArray = npt.NDArray[np.float64]
Vec3 = tuple[float, float, float]


def _id(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> int:
    index = int(mujoco.mj_name2id(model, kind, name))
    if index < 0:
        what = kind.name.removeprefix("mjOBJ_").lower()
        raise SimError(f"the model has no {what} named {name!r}; was it built by sim.mjcf?")
    return index


@dataclass(frozen=True)
class SceneIndex:
    """Ids and state addresses of the scene's named parts in one compiled model."""

    quad_body: int
    qpos_adr: int  # 7 values: position (3), quaternion (4)
    qvel_adr: int  # 6 values: linear velocity (world), angular velocity (body)
    motors: tuple[int, ...]  # actuator ids in rotor order
    accel_adr: int
    gyro_adr: int
    down_camera: int
    depth_camera: int
    top_camera: int
    robot_mocap: tuple[int, ...]  # mocap ids in arena.robots order

    def __post_init__(self) -> None:
        first = self.motors[0] if self.motors else 0
        if self.motors != tuple(range(first, first + NUM_ROTORS)):
            raise SimError(f"motors: actuator ids {self.motors} are not {NUM_ROTORS} in a row "
                           "(sim.mjcf declares the motors together, in rotor order)")
        if self.gyro_adr != self.accel_adr + 3:
            raise SimError(f"the gyro's sensor data (at {self.gyro_adr}) does not follow the "
                           f"accelerometer's (at {self.accel_adr}); sim.mjcf declares them "
                           "in a row")

    @functools.cached_property
    def motor_ctrl(self) -> slice:
        """Where the motors' thrusts are in ``data.ctrl`` (one slice: quicker to write than
        a list of ids)."""
        return slice(self.motors[0], self.motors[0] + NUM_ROTORS)

    @functools.cached_property
    def imu_values(self) -> slice:
        """Where the IMU's six values are in ``data.sensordata``: specific force, then
        angular rate."""
        return slice(self.accel_adr, self.accel_adr + 6)

    @classmethod
    def from_model(cls, model: mujoco.MjModel, arena: ArenaSpec) -> SceneIndex:
        """Resolve every name; raises :class:`SimError` if the model lacks one."""
        obj = mujoco.mjtObj
        joint = _id(model, obj.mjOBJ_JOINT, QUAD_JOINT)
        robot_bodies = (
            _id(model, obj.mjOBJ_BODY, robot_body_name(r.marker_id)) for r in arena.robots
        )
        return cls(
            quad_body=_id(model, obj.mjOBJ_BODY, QUAD_BODY),
            qpos_adr=int(model.jnt_qposadr[joint]),
            qvel_adr=int(model.jnt_dofadr[joint]),
            motors=tuple(_id(model, obj.mjOBJ_ACTUATOR, motor_name(i)) for i in range(NUM_ROTORS)),
            accel_adr=int(model.sensor_adr[_id(model, obj.mjOBJ_SENSOR, ACCEL_SENSOR)]),
            gyro_adr=int(model.sensor_adr[_id(model, obj.mjOBJ_SENSOR, GYRO_SENSOR)]),
            down_camera=_id(model, obj.mjOBJ_CAMERA, DOWN_CAMERA),
            depth_camera=_id(model, obj.mjOBJ_CAMERA, DEPTH_CAMERA),
            top_camera=_id(model, obj.mjOBJ_CAMERA, TOP_CAMERA),
            robot_mocap=tuple(int(model.body_mocapid[b]) for b in robot_bodies),
        )


@dataclass(frozen=True, eq=False)
class SceneViews:
    """Views into one ``MjData`` at a :class:`SceneIndex`'s addresses: they read and write
    the data in place, and cost nothing per use (slicing the data anew every update does).
    Valid as long as that ``MjData`` lives; :meth:`of` makes them."""

    quad_qpos: FloatArray
    """The quadrotor's position (3) and quaternion (4), ``data.qpos``."""
    quad_qvel: FloatArray
    """Its linear velocity (3, world) and angular velocity (3, body), ``data.qvel``."""
    quad_force: FloatArray
    """The force (3, world) applied to its body, ``data.xfrc_applied``."""
    motor_ctrl: FloatArray
    """The motors' thrusts in rotor order, ``data.ctrl``."""
    imu: FloatArray
    """The IMU's specific force (3), then angular rate (3), ``data.sensordata``."""

    @classmethod
    def of(cls, data: mujoco.MjData, index: SceneIndex) -> SceneViews:
        return cls(
            quad_qpos=data.qpos[index.qpos_adr : index.qpos_adr + 7],
            quad_qvel=data.qvel[index.qvel_adr : index.qvel_adr + 6],
            quad_force=data.xfrc_applied[index.quad_body, :3],
            motor_ctrl=data.ctrl[index.motor_ctrl],
            imu=data.sensordata[index.imu_values],
        )


class QuadState(NamedTuple):
    """Ground-truth rigid-body state of the quadrotor (evaluation only, never to the companion).

    ``position`` [m] and ``velocity`` [m/s] in the ENU world; ``quaternion`` (w, x, y, z)
    rotates body FLU into world; ``angular_velocity`` [rad/s] in the body frame.
    """

    position: FloatArray
    quaternion: FloatArray
    velocity: FloatArray
    angular_velocity: FloatArray


def quad_state(data: mujoco.MjData, index: SceneIndex) -> QuadState:
    """Copy of the quadrotor's free-joint state."""
    qpos = data.qpos[index.qpos_adr : index.qpos_adr + 7].copy()
    qvel = data.qvel[index.qvel_adr : index.qvel_adr + 6].copy()
    return QuadState(  # views of the two copies
        position=qpos[:3],
        quaternion=qpos[3:],
        velocity=qvel[:3],
        angular_velocity=qvel[3:],
    )


def place_quadrotor(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    index: SceneIndex,
    position: Vec3,
    yaw: float = 0.0,
) -> None:
    """Teleport the quadrotor to ``position`` [m] with heading ``yaw`` [rad], at rest."""
    adr = index.qpos_adr
    data.qpos[adr : adr + 3] = position
    data.qpos[adr + 3 : adr + 7] = (math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0))
    data.qvel[index.qvel_adr : index.qvel_adr + 6] = 0.0
    mujoco.mj_forward(model, data)


def set_motor_thrusts(data: mujoco.MjData, index: SceneIndex, thrusts: npt.ArrayLike) -> None:
    """Apply actual rotor thrusts [N] (the :class:`~sim.quadrotor.MotorModel` output)."""
    data.ctrl[index.motor_ctrl] = np.asarray(thrusts, dtype=np.float64).reshape(NUM_ROTORS)


def set_robot_poses(data: mujoco.MjData, index: SceneIndex, arena: ArenaSpec, t: float,
                    drives: Mapping[int, StraightDrive] | None = None) -> None:
    """Move every ground robot's mocap body to its pose at time ``t`` [s]: along its
    route, or, for a robot (by its index in ``arena.robots``) in ``drives`` from the
    drive's start on, along the drive."""
    mocap_pos, mocap_quat = data.mocap_pos, data.mocap_quat
    for i, (robot, mocap) in enumerate(zip(arena.robots, index.robot_mocap, strict=True)):
        drive = drives.get(i) if drives else None
        (x, y), yaw = (drive.pose(t) if drive is not None and t >= drive.start_s
                       else robot_pose(robot, t))
        mocap_pos[mocap] = (x, y, 0.0)
        mocap_quat[mocap] = (math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0))


def read_imu(data: mujoco.MjData, index: SceneIndex) -> ImuSample:
    """True specific force [m/s^2] and angular rate [rad/s] at the IMU site (body FLU).

    Sensors are computed inside ``mj_step`` *before* integrating, so after a step they
    describe the state at the start of it (one step old); ``mj_forward`` refreshes them.
    At rest the accelerometer reads ``+g`` on z.
    """
    values = data.sensordata[index.imu_values].copy()
    return ImuSample(accel=values[:3], gyro=values[3:])
