"""The world loop: MuJoCo physics in lockstep with the node runtime's executor.

One function, :func:`run_world`, over injected parts. Each part runs at a fixed rate that
must divide the physics rate (checked, not assumed); between part updates MuJoCo steps in
one batch. At every update time the executor first runs the node callbacks due by then,
the parts run in the order given, and the executor handles what they published, so
sensors publish at exact sample times and nodes see them at those times. Null objects
(:class:`MotorsOff`, :class:`NoWind`, :class:`NeverStop`) stand in for the parts a run
does not need.

Time is an integer: physics step ``k`` is at ``k * 1e9 // physics_hz`` nanoseconds.
The physics rate, the parts' default rates and the crash thresholds are tuning, not code:
:class:`WorldParams`, from ``config/sim_world.yaml`` (:func:`world_params`). A keyword
given in code (``RobotMotion(rate_hz=10.0)``, ``Scene.build(..., physics_hz=500)``) wins.
Ground truth (:class:`Trajectory`, crash reports) is for evaluation only; companion nodes
see only the topics the parts publish.
"""

from __future__ import annotations

import bisect
import functools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Protocol

import mujoco
import numpy as np
import numpy.typing as npt

from runtime import DeterministicExecutor
from runtime.clock import NS_PER_S
from runtime.errors import ParameterError
from runtime.parameters import load_parameters, param, validate_parameters
from sim.arena import ArenaSpec, Lighting, StraightDrive
from sim.errors import SimError
from sim.mjcf import build_model
from sim.quadrotor import (
    NUM_ROTORS,
    ImuNoiseModel,
    ImuNoiseParams,
    ImuSample,
    ImuValues,
    MotorModel,
    QuadrotorParams,
)
from sim.scene import (
    SceneIndex,
    SceneViews,
    place_quadrotor,
    set_robot_poses,
)

FloatArray = npt.NDArray[np.float64]

WORLD_NODE_NAME = "sim_world"
"""The world's section in its ROS 2 parameter file, ``config/sim_world.yaml``."""


class RateError(SimError, ValueError):
    """A part's rate that does not divide the physics rate."""


def divides(rate_hz: float, physics_hz: int) -> bool:
    """Whether a part at ``rate_hz`` runs every whole number (>= 1) of physics steps."""
    if not rate_hz > 0:
        return False
    steps = physics_hz / rate_hz
    return abs(steps - round(steps)) <= 1e-9 and round(steps) >= 1


@dataclass(frozen=True)
class CrashParams:
    """When the crash detector ends a flight (``crash`` in ``config/sim_world.yaml``)."""

    rate_hz: float = param(unit="Hz", range=(1.0, 10000.0))
    """Checks per second (must divide the physics rate)."""
    max_touchdown_speed: float = param(unit="m/s", range=(0.0, 20.0), lo_open=True)
    """A contact with the floor or a pad faster than this (downwards) is a crash."""
    max_tilt_deg: float = param(unit="deg", range=(0.0, 180.0), lo_open=True)
    """A body tilt beyond this, airborne or landed, is a crash."""

    def __post_init__(self) -> None:
        validate_parameters(self)


@dataclass(frozen=True)
class WorldParams:
    """The world loop's tuning (``config/sim_world.yaml``); ranges declared once.

    Every ``*rate_hz`` must divide ``physics_hz``: checked here, so a bad file is refused
    with the key's name before anything runs.
    """

    crash: CrashParams
    physics_hz: int = param(unit="Hz", range=(100, 100000))
    """MuJoCo steps per second; every part's rate divides it."""
    actuation_rate_hz: float = param(unit="Hz", range=(1.0, 10000.0))
    """Motor command updates per second (the firmware's loop rate replaces it in SITL)."""
    robots_rate_hz: float = param(unit="Hz", range=(1.0, 10000.0))
    """Ground-robot pose updates per second."""
    trajectory_rate_hz: float = param(unit="Hz", range=(1.0, 10000.0))
    """Ground-truth samples recorded per second (evaluation only)."""

    def __post_init__(self) -> None:
        validate_parameters(self)
        rates = [("actuation_rate_hz", self.actuation_rate_hz),
                 ("robots_rate_hz", self.robots_rate_hz),
                 ("trajectory_rate_hz", self.trajectory_rate_hz),
                 ("crash.rate_hz", self.crash.rate_hz)]
        for key, rate_hz in rates:
            if not divides(rate_hz, self.physics_hz):
                raise ParameterError(
                    f"{rate_hz:g} Hz does not divide the physics rate {self.physics_hz} Hz "
                    f"(physics_hz)", key=key)


def world_params(path: Path | None = None) -> WorldParams:
    """:class:`WorldParams` from ``path`` (default: ``sim_world.yaml`` in the config folder)."""
    return load_parameters(WorldParams, WORLD_NODE_NAME, path)


@dataclass
class Scene:
    """A compiled arena with the quadrotor: model, data and resolved names."""

    arena: ArenaSpec
    quad: QuadrotorParams
    model: mujoco.MjModel
    data: mujoco.MjData
    index: SceneIndex
    physics_hz: int

    @classmethod
    def build(
        cls,
        arena: ArenaSpec,
        quad: QuadrotorParams | None = None,
        lighting: Lighting | None = None,
        physics_hz: int | None = None,
    ) -> Scene:
        """The compiled scene; ``physics_hz`` defaults to ``config/sim_world.yaml``'s."""
        if physics_hz is None:
            physics_hz = world_params().physics_hz
        if physics_hz <= 0:
            raise RateError(f"physics_hz: {physics_hz} must be > 0")
        quad = quad or QuadrotorParams()
        model = build_model(arena, quad, lighting)
        model.opt.timestep = 1.0 / physics_hz
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        return cls(arena, quad, model, data, SceneIndex.from_model(model, arena), physics_hz)

    @functools.cached_property
    def views(self) -> SceneViews:
        """Views into :attr:`data` that the parts read and write (made once)."""
        return SceneViews.of(self.data, self.index)

    def time_ns(self, step: int) -> int:
        return step * NS_PER_S // self.physics_hz

    def period_steps(self, name: str, rate_hz: float) -> int:
        """Physics steps per period of a part running at ``rate_hz``; RateError otherwise."""
        if not divides(rate_hz, self.physics_hz):
            raise RateError(
                f"{name}: {rate_hz} Hz does not divide the physics rate {self.physics_hz} Hz"
            )
        return round(self.physics_hz / rate_hz)

    def place_at_takeoff(self, height: float = 0.0) -> None:
        """Put the quadrotor on (or ``height`` m above) the start pad, at rest."""
        x, y, z = self.arena.takeoff_position
        z_body = z + self.quad.leg_height + height
        place_quadrotor(self.model, self.data, self.index, (x, y, z_body))


class Part(Protocol):
    """Something the world runs at a fixed rate: actuation, a sensor, a recorder."""

    name: str
    rate_hz: float

    def update(self, t_ns: int, scene: Scene) -> None: ...


class Stop(Protocol):
    """Decides when a run is over (mission done, test condition met)."""

    def done(self, t_ns: int, scene: Scene) -> bool: ...


class NeverStop:
    """Run for the whole duration."""

    def done(self, t_ns: int, scene: Scene) -> bool:
        return False


class StopWhen:
    """Stop as soon as ``condition()`` holds (a mission done, a test's state reached)."""

    def __init__(self, condition: Callable[[], object]) -> None:
        self.condition = condition

    def done(self, t_ns: int, scene: Scene) -> bool:
        return bool(self.condition())


class MotorCommands(Protocol):
    """What decides the rotor thrust commands [N]: the flight controller, or a test input."""

    def commands(self, t_ns: int, scene: Scene) -> FloatArray: ...


class MotorsOff:
    """Zero thrust (a drone that is not flying)."""

    def commands(self, t_ns: int, scene: Scene) -> FloatArray:
        return np.zeros(NUM_ROTORS)


@dataclass
class ConstantThrust:
    """The same thrust on every rotor; ``ConstantThrust.hover(params)`` balances gravity."""

    thrust: float

    @classmethod
    def hover(cls, params: QuadrotorParams) -> ConstantThrust:
        return cls(params.hover_thrust)

    def commands(self, t_ns: int, scene: Scene) -> FloatArray:
        return np.full(NUM_ROTORS, self.thrust)


class Wind(Protocol):
    """A disturbance force [N] on the quadrotor, in the world frame."""

    def force(self, t_ns: int) -> FloatArray: ...


_NO_FORCE = np.zeros(3)
_NO_FORCE.setflags(write=False)


class NoWind:
    """Still air: no force (one shared read-only zero vector, not a new one per update)."""

    def force(self, t_ns: int) -> FloatArray:
        return _NO_FORCE


@dataclass
class Actuation:
    """Runs the motor commands through the motor lag and applies thrust and wind.

    The commands are held over one period (zero-order hold, as an ESC update would), and
    the motor model integrates the lag exactly over it.
    """

    commands: MotorCommands
    motors: MotorModel
    wind: Wind = field(default_factory=NoWind)
    rate_hz: float = field(default_factory=lambda: world_params().actuation_rate_hz)
    name: str = "actuation"

    def update(self, t_ns: int, scene: Scene) -> None:
        thrust = self.motors.step_values(self.commands.commands(t_ns, scene), 1.0 / self.rate_hz)
        views = scene.views
        views.motor_ctrl[:] = thrust
        views.quad_force[:] = self.wind.force(t_ns)


@dataclass
class Imu:
    """The flight controller's IMU: noisy, biased specific force and rates (body FLU).

    Samples MuJoCo's accelerometer and gyro at ``rate_hz`` through the noise model; the
    latest sample and its time are what the flight controller reads. MuJoCo computes
    sensors at the start of a step, so a sample is one physics step old (0.67 ms at
    1.5 kHz), as a real IMU's filter delay would make it. The rate is the flight
    controller's to choose (``imu_rate_hz`` in ``config/fcu_firmware.yaml``), so it has
    no default here.
    """

    noise: ImuNoiseModel
    rate_hz: float
    name: str = "imu"
    latest_values: ImuValues | None = None
    """The latest sample as six floats: specific force (x, y, z), then angular rate."""
    latest_t_ns: int = -1
    _latest: ImuSample | None = field(default=None, init=False, repr=False)

    @classmethod
    def seeded(cls, seed: int, *, rate_hz: float, params: ImuNoiseParams | None = None) -> Imu:
        return cls(ImuNoiseModel(params or ImuNoiseParams(), np.random.default_rng(seed)),
                   rate_hz=rate_hz)

    @property
    def latest(self) -> ImuSample | None:
        """The latest sample as arrays (made from :attr:`latest_values` when first read)."""
        if self._latest is None and self.latest_values is not None:
            self._latest = ImuSample.of(self.latest_values)
        return self._latest

    def update(self, t_ns: int, scene: Scene) -> None:
        truth = scene.views.imu.tolist()  # accel then gyro, as floats
        self.latest_values = self.noise.noisy_values(truth, 1.0 / self.rate_hz)
        self._latest = None
        self.latest_t_ns = t_ns


@dataclass
class RobotMotion:
    """Moves the ground robots along their paths (kinematic, mocap bodies), or a robot in
    ``drives`` (by its index in the arena's robots) along its drive once it has begun
    (the ``robot_across`` fault)."""

    rate_hz: float = field(default_factory=lambda: world_params().robots_rate_hz)
    name: str = "robots"
    drives: dict[int, StraightDrive] = field(default_factory=dict)

    def update(self, t_ns: int, scene: Scene) -> None:
        set_robot_poses(scene.data, scene.index, scene.arena, t_ns / NS_PER_S, self.drives)


@dataclass(frozen=True)
class Trajectory:
    """Ground-truth samples: time [s], position [m] (ENU), quaternion (w, x, y, z) body FLU
    to world, velocity [m/s] (world)."""

    t: FloatArray
    position: FloatArray
    quaternion: FloatArray
    velocity: FloatArray

    def __len__(self) -> int:
        return len(self.t)


@dataclass
class TrajectoryRecorder:
    """Samples the quadrotor's true state for evaluation."""

    rate_hz: float = field(default_factory=lambda: world_params().trajectory_rate_hz)
    name: str = "trajectory"
    _rows: list[tuple[float, ...]] = field(default_factory=list)

    def update(self, t_ns: int, scene: Scene) -> None:
        views = scene.views
        vx, vy, vz, _, _, _ = views.quad_qvel.tolist()
        self._rows.append((t_ns / NS_PER_S, *views.quad_qpos.tolist(), vx, vy, vz))

    def trajectory(self) -> Trajectory:
        rows = np.array(self._rows).reshape(-1, 11)
        return Trajectory(rows[:, 0], rows[:, 1:4], rows[:, 4:8], rows[:, 8:11])


class WorldStatus(Enum):
    COMPLETED = "completed"  # ran for the whole duration
    STOPPED = "stopped"  # the stop condition ended the run
    CRASHED = "crashed"  # the vehicle hit something or flipped over


@dataclass(frozen=True)
class Crash:
    """What ended the flight: when, where, and why."""

    t_s: float
    position: tuple[float, float, float]
    reason: str


@dataclass
class CrashDetector:
    """A crash is a contact with a wall, an obstacle or a robot, a touchdown faster than
    ``params.max_touchdown_speed``, or a tilt beyond ``params.max_tilt_deg`` while
    airborne or landed. ``params`` defaults to ``crash`` in ``config/sim_world.yaml``."""

    params: CrashParams = field(default_factory=lambda: world_params().crash)
    name: str = "crash_detector"
    rate_hz: float = field(init=False)
    crash: Crash | None = None
    _geoms: tuple[frozenset[int], frozenset[int]] | None = None

    def __post_init__(self) -> None:
        self.rate_hz = self.params.rate_hz
        # the body z axis's world z component below which the tilt is a crash
        self._min_up_z = math.cos(math.radians(self.params.max_tilt_deg))

    def _geom_sets(self, scene: Scene) -> tuple[frozenset[int], frozenset[int]]:
        """The geoms a drone may touch down on, and the quadrotor body's own (looked up
        once: a detector watches one scene)."""
        if self._geoms is None:
            model = scene.model
            names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
                     for g in range(model.ngeom)]
            # the floor and the pads are where a drone is allowed to touch down
            soft = frozenset(g for g, n in enumerate(names) if n == "floor" or n.startswith("pad_"))
            bodies = model.geom_bodyid.tolist()
            own = frozenset(g for g, body in enumerate(bodies) if body == scene.index.quad_body)
            self._geoms = soft, own
        return self._geoms

    def update(self, t_ns: int, scene: Scene) -> None:
        if self.crash is not None:
            return
        px, py, pz, _, x, y, _ = scene.views.quad_qpos.tolist()  # position, quaternion
        up_z = 1.0 - 2.0 * (x * x + y * y)  # body z axis, world z component
        reason = None
        if up_z < self._min_up_z:
            reason = f"tilt {math.degrees(math.acos(max(-1.0, min(1.0, up_z)))):.0f} deg"
        if reason is None and scene.data.ncon == 0:
            return  # in the air and upright: the common case
        reason = self._contact_reason(scene) or reason
        if reason is not None:
            self.crash = Crash(t_ns / NS_PER_S, (px, py, pz), reason)

    def _contact_reason(self, scene: Scene) -> str | None:
        """Why the first bad contact of the quadrotor is a crash; None if none is."""
        soft, own = self._geom_sets(scene)
        descent = -float(scene.views.quad_qvel[2])  # what a touchdown on a soft geom is judged by
        too_fast = descent > self.params.max_touchdown_speed
        for g1, g2 in scene.data.contact.geom.tolist():
            other = g2 if g1 in own else g1
            if other in own:
                continue
            if other not in soft:
                name = mujoco.mj_id2name(scene.model, mujoco.mjtObj.mjOBJ_GEOM, other)
                return f"hit {name or f'geom {other}'}"
            if too_fast:
                return f"touchdown at {descent:.1f} m/s"
        return None


@dataclass(frozen=True)
class WorldResult:
    """How a run ended, and the ground truth it produced (for evaluation only)."""

    status: WorldStatus
    sim_time_s: float
    physics_steps: int
    wall_time_s: float
    trajectory: Trajectory
    crash: Crash | None
    cpu_time_s: float = 0.0
    """Host CPU time of this process over the run (all threads): unlike the wall time, it
    hardly depends on what else the machine runs."""

    @property
    def real_time_factor(self) -> float:
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf

    @property
    def cpu_time_factor(self) -> float:
        """Simulated seconds per second of this process's CPU time."""
        return self.sim_time_s / self.cpu_time_s if self.cpu_time_s > 0 else math.inf


class _UpdatePlan:
    """Which parts are due at a physics step, and the next step at which any is.

    A part with a period of ``p`` steps runs at every multiple of ``p``; the pattern
    repeats every ``cycle`` steps (the periods' least common multiple, which divides the
    physics rate), so it is worked out once per phase of the cycle, not at every step.
    """

    def __init__(self, parts: Sequence[Part], periods: Sequence[int]) -> None:
        self.cycle = cycle = math.lcm(*periods)
        # the phases at which something is due (0 always is), and what is, in part order
        self._phases = sorted({k for p in periods for k in range(0, cycle, p)})
        self._due = {k: tuple(part for part, p in zip(parts, periods, strict=True) if k % p == 0)
                     for k in self._phases}
        # from such a phase, the steps to the next one
        following = [*self._phases[1:], cycle]
        self._gap = {k: n - k for k, n in zip(self._phases, following, strict=True)}

    def due(self, step: int) -> tuple[Part, ...]:
        """The parts due at ``step``, in their order."""
        return self._due.get(step % self.cycle, ())

    def next_due(self, step: int) -> int:
        """The first step after ``step`` at which a part is due."""
        phase = step % self.cycle
        gap = self._gap.get(phase)
        if gap is None:  # nothing due at step (a run's first step can be such)
            later = bisect.bisect_right(self._phases, phase)
            gap = (self._phases[later] if later < len(self._phases) else self.cycle) - phase
        return step + gap


def run_world(
    scene: Scene,
    executor: DeterministicExecutor,
    *,
    duration_s: float,
    parts: Sequence[Part] = (),
    stop: Stop | None = None,
    crash_detector: CrashDetector | None = None,
    recorder: TrajectoryRecorder | None = None,
) -> WorldResult:
    """Step ``scene`` for ``duration_s`` with ``parts``, the executor in lockstep.

    Parts run at every multiple of their period in [start, end), in the order given; the
    crash detector and the recorder run after them. The run ends early when ``stop`` says
    so or on a crash; calling again continues from where the last run ended.
    """
    if not duration_s > 0:
        raise SimError(f"duration_s: {duration_s} must be > 0")
    stop = stop or NeverStop()
    crash_detector = crash_detector or CrashDetector()
    recorder = recorder or TrajectoryRecorder()
    schedule = [*parts, crash_detector, recorder]
    plan = _UpdatePlan(schedule, [scene.period_steps(p.name, p.rate_hz) for p in schedule])
    start_step = round(scene.data.time * scene.physics_hz)
    end_step = start_step + round(duration_s * scene.physics_hz)
    step = start_step
    status = WorldStatus.COMPLETED
    wall_start = time.perf_counter()
    cpu_start = time.process_time()
    model, data = scene.model, scene.data
    # parts run on absolute multiples of their period, so successive runs continue the
    # same schedule; a run covers [start, end) and the next one starts where it ended
    due = plan.due(step)
    while True:
        t_ns = max(scene.time_ns(step), executor.now_ns())
        executor.spin_until(t_ns)  # node callbacks due up to now; the clock reads t_ns
        if step >= end_step:
            break
        for part in due:
            part.update(t_ns, scene)
        executor.spin_until(t_ns)  # what the parts just published, at its sample time
        if crash_detector.crash is not None:
            status = WorldStatus.CRASHED
        elif stop.done(t_ns, scene):
            status = WorldStatus.STOPPED
        if status is not WorldStatus.COMPLETED:
            mujoco.mj_step(model, data)  # this step's parts ran: a next run starts after it
            step += 1
            break
        target = min(plan.next_due(step), end_step)
        mujoco.mj_step(model, data, nstep=target - step)
        step = target
        due = plan.due(step)
    return WorldResult(
        status=status,
        sim_time_s=(step - start_step) / scene.physics_hz,
        physics_steps=step - start_step,
        wall_time_s=time.perf_counter() - wall_start,
        trajectory=recorder.trajectory(),
        crash=crash_detector.crash,
        cpu_time_s=time.process_time() - cpu_start,
    )


__all__ = [
    "WORLD_NODE_NAME",
    "Actuation",
    "ConstantThrust",
    "Crash",
    "CrashDetector",
    "CrashParams",
    "Imu",
    "MotorCommands",
    "MotorsOff",
    "NeverStop",
    "NoWind",
    "Part",
    "RateError",
    "RobotMotion",
    "Scene",
    "Stop",
    "StopWhen",
    "Trajectory",
    "TrajectoryRecorder",
    "WorldParams",
    "WorldResult",
    "WorldStatus",
    "divides",
    "run_world",
    "world_params",
]
