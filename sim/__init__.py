"""MuJoCo arena, quadrotor, sensors and simulated flight controller: the only MuJoCo user."""

# Pure parts only: importing sim must not import mujoco (MUJOCO_GL is read at import time).
# The MuJoCo-facing modules are imported by path: sim.mjcf, sim.scene, sim.render.
from sim.arena import (
    ArenaSpec,
    BoxObstacle,
    FieldSpec,
    GroundRobot,
    Lighting,
    Pad,
    RobotPose,
    StraightDrive,
    default_arena,
    load_arena,
    robot_pose,
)
from sim.arena_generator import GeneratorConfig, generate_arena
from sim.errors import ArenaError, SimError
from sim.quadrotor import (
    CameraParams,
    ImuNoiseModel,
    ImuNoiseParams,
    ImuSample,
    ImuValues,
    MotorModel,
    OnboardCameras,
    QuadrotorParams,
    allocation_matrix,
    mix,
    onboard_cameras,
)

__all__: list[str] = [
    "ArenaError",
    "ArenaSpec",
    "BoxObstacle",
    "CameraParams",
    "FieldSpec",
    "GeneratorConfig",
    "GroundRobot",
    "ImuNoiseModel",
    "ImuNoiseParams",
    "ImuSample",
    "ImuValues",
    "Lighting",
    "MotorModel",
    "OnboardCameras",
    "Pad",
    "QuadrotorParams",
    "RobotPose",
    "SimError",
    "StraightDrive",
    "allocation_matrix",
    "default_arena",
    "generate_arena",
    "load_arena",
    "mix",
    "onboard_cameras",
    "robot_pose",
]
