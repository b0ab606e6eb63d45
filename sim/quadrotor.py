"""X-frame contest quadrotor: parameters, rotor layout, mixer, motor lag and IMU noise.

Pure numpy (and the parameter loader for the cameras' config); the MJCF is built from
these parameters by :mod:`sim.mjcf`.

Frames: body FLU (x forward, y left, z up, REP 103) inside the ENU MuJoCo world. Rotors
follow PX4's quad-X numbering, with index ``i`` = PX4 motor ``i + 1``:

    index  position     spin (seen from above)
    0      front-right  CCW
    1      rear-left    CCW
    2      front-left   CW
    3      rear-right   CW

Diagonal pairs spin the same way. A rotor pushes along body +z with thrust ``T`` and
twists the body about +z by ``-spin * (km / kf) * T`` (the reaction to its drag torque),
so the CW pair yaws the body left (CCW, positive about +z).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from enum import IntEnum
from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from runtime.errors import ParameterError
from runtime.parameters import config_path, load_parameters, param, validate_parameters

GRAVITY = 9.81  # m/s^2, also the MuJoCo model's gravity
NUM_ROTORS = 4

Vec3 = tuple[float, float, float]
FloatArray = npt.NDArray[np.float64]


class Spin(IntEnum):
    """Rotor spin direction seen from above: +1 counter-clockwise, -1 clockwise."""

    CCW = 1
    CW = -1


# (forward sign, left sign, spin) per rotor index: PX4 quad-X order.
_ROTOR_LAYOUT: tuple[tuple[int, int, Spin], ...] = (
    (1, -1, Spin.CCW),  # front-right
    (-1, 1, Spin.CCW),  # rear-left
    (1, 1, Spin.CW),  # front-left
    (-1, -1, Spin.CW),  # rear-right
)


CAMERAS_NODE_NAME = "sim_cameras"
"""The onboard cameras' section in ``config/sim_sensors.yaml`` (next to the sensors node's)."""
CAMERAS_FILE = "sim_sensors.yaml"
"""The file, in the config folder, that describes the onboard cameras."""


@dataclass(frozen=True)
class CameraParams:
    """A body-fixed pinhole camera: image size, vertical field of view, mounting, range."""

    width: int = param(unit="px", range=(1, 4096))
    height: int = param(unit="px", range=(1, 4096))
    fovy_deg: float = param(unit="deg", range=(0.0, 179.0), lo_open=True)
    """Vertical field of view."""
    position: tuple[float, ...] = param(unit="m", range=(-2.0, 2.0))
    """Optical centre in the body frame (FLU), three values."""
    near: float = param(unit="m", range=(0.0, 100.0), lo_open=True)
    """Closest distance the camera sees (depth pixels nearer are dropped)."""
    far: float = param(unit="m", range=(0.0, 1000.0), lo_open=True)
    """Farthest distance the camera sees."""

    def __post_init__(self) -> None:
        validate_parameters(self)
        if len(self.position) != 3:
            raise ParameterError(f"{self.position!r} must be 3 values (x, y, z)", key="position")
        if not self.near < self.far:
            raise ParameterError(f"{self.far!r} must be beyond near ({self.near!r})", key="far")

    @property
    def fovy(self) -> float:
        """Vertical field of view [rad]."""
        return math.radians(self.fovy_deg)


@dataclass(frozen=True)
class OnboardCameras:
    """The airframe's cameras (``sim_cameras`` in ``config/sim_sensors.yaml``)."""

    down_camera: CameraParams
    """Looks down; reads the markers (seed 003)."""
    depth_camera: CameraParams
    """Looks forward; its depth image becomes the point cloud for mapping."""


def onboard_cameras(path: Path | None = None) -> OnboardCameras:
    """The cameras from ``path`` (default: ``sim_sensors.yaml`` in the config folder)."""
    return load_parameters(OnboardCameras, CAMERAS_NODE_NAME,
                           path if path is not None else config_path(CAMERAS_FILE))


@dataclass(frozen=True)
class QuadrotorParams:
    """Physical constants of a 450 mm-class contest quadrotor (SI units, body FLU).

    Defaults: 1.5 kg, 0.225 m arms (450 mm motor-to-motor diagonal), 10" props, thrust to
    weight 2.5, 30 ms motor time constant; a downward camera and a forward depth camera as
    ``config/sim_sensors.yaml`` describes them (:func:`onboard_cameras`).
    """

    mass: float = 1.5  # kg
    inertia: Vec3 = (0.012, 0.012, 0.022)  # kg m^2, principal moments about body x, y, z
    arm_length: float = 0.225  # m, body centre to rotor axis
    rotor_height: float = 0.04  # m, rotor plane above the body origin
    rotor_radius: float = 0.127  # m, 10" propeller
    max_motor_thrust: float = 9.2  # N per rotor
    motor_tau: float = 0.03  # s, first-order time constant commanded -> actual thrust
    kf: float = 1.0e-5  # N/(rad/s)^2, thrust = kf * omega^2
    km: float = 1.6e-7  # N m/(rad/s)^2, drag torque = km * omega^2
    leg_height: float = 0.14  # m, body origin above the landing-gear contact points
    down_camera: CameraParams = field(default_factory=lambda: onboard_cameras().down_camera)
    depth_camera: CameraParams = field(default_factory=lambda: onboard_cameras().depth_camera)

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, float) and not (math.isfinite(value) and value > 0.0):
                raise ParameterError(f"QuadrotorParams.{f.name}: {value!r} must be > 0")
        ix, iy, iz = self.inertia
        if min(self.inertia) <= 0.0 or ix + iy < iz or iy + iz < ix or iz + ix < iy:
            raise ParameterError(
                f"QuadrotorParams.inertia: {self.inertia} is not a physical inertia "
                "(positive, triangle inequality)"
            )
        if self.thrust_to_weight <= 1.0:
            raise ParameterError(
                f"QuadrotorParams.max_motor_thrust: {self.max_motor_thrust} N gives thrust to "
                f"weight {self.thrust_to_weight:.2f}; the drone could not lift off"
            )
        if self.rotor_radius >= self.arm_length * math.sqrt(2.0) / 2.0:
            raise ParameterError(
                f"QuadrotorParams.rotor_radius: {self.rotor_radius} m, neighbouring rotors "
                f"on {self.arm_length} m arms would touch"
            )

    @property
    def weight(self) -> float:
        """Weight [N]."""
        return self.mass * GRAVITY

    @property
    def thrust_to_weight(self) -> float:
        """Total maximum thrust over weight."""
        return NUM_ROTORS * self.max_motor_thrust / self.weight

    @property
    def hover_thrust(self) -> float:
        """Thrust per rotor that balances gravity [N]."""
        return self.weight / NUM_ROTORS

    @property
    def torque_ratio(self) -> float:
        """Yaw drag torque per newton of thrust, ``km / kf`` [m]."""
        return self.km / self.kf

    @property
    def max_rotor_speed(self) -> float:
        """Rotor speed at full thrust [rad/s]."""
        return math.sqrt(self.max_motor_thrust / self.kf)


class Rotor(NamedTuple):
    """One rotor: hub position in the body frame [m] and spin direction."""

    position: Vec3
    spin: Spin


def rotors(params: QuadrotorParams) -> tuple[Rotor, ...]:
    """The four rotors in PX4 quad-X order (see the module docstring)."""
    d = params.arm_length / math.sqrt(2.0)
    return tuple(
        Rotor((fwd * d, left * d, params.rotor_height), spin) for fwd, left, spin in _ROTOR_LAYOUT
    )


@functools.cache
def _allocation(params: QuadrotorParams) -> tuple[FloatArray, FloatArray]:
    rows = []
    for rotor in rotors(params):
        x, y, _ = rotor.position
        rows.append((1.0, y, -x, -int(rotor.spin) * params.torque_ratio))
    matrix = np.array(rows, dtype=np.float64).T
    inverse = np.linalg.inv(matrix).astype(np.float64)
    matrix.setflags(write=False)
    inverse.setflags(write=False)
    return matrix, inverse


def allocation_matrix(params: QuadrotorParams) -> FloatArray:
    """``A`` with ``[T, tau_x, tau_y, tau_z] = A @ f`` for rotor thrusts ``f`` (read-only).

    ``T`` is the collective thrust along body +z [N], ``tau`` the body torque [N m] about
    the body axes (FLU) through the centre of mass.
    """
    return _allocation(params)[0]


def mix(params: QuadrotorParams, thrust: float, torque: npt.ArrayLike) -> FloatArray:
    """Rotor thrusts [N] giving collective ``thrust`` [N] and body ``torque`` (x, y, z) [N m].

    Exact inverse of :func:`allocation_matrix`, not clipped: the caller decides how to
    saturate (the motor model clips to ``[0, max_motor_thrust]``).
    """
    wrench = np.concatenate(([thrust], np.asarray(torque, dtype=np.float64).reshape(3)))
    result: FloatArray = _allocation(params)[1] @ wrench
    return result


class MotorModel:
    """First-order motor lag: actual thrust follows the command with time constant ``tau``.

    ``step`` holds the command constant over ``dt`` and integrates exactly:
    ``T += (1 - exp(-dt / tau)) * (clip(cmd) - T)``, so any ``dt`` is stable. Commands are
    clipped to ``[0, max_motor_thrust]``. The four thrusts are Python floats inside (cheaper
    than numpy on four values, and rounded the same); :meth:`step` returns a new array,
    :meth:`step_values` the floats.
    """

    def __init__(self, params: QuadrotorParams, initial_thrust: npt.ArrayLike = 0.0) -> None:
        self._tau = params.motor_tau
        self._max = params.max_motor_thrust
        self._kf = params.kf
        self._thrust: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self._dt = math.nan  # the step the lag factor below is for (none yet)
        self._alpha = math.nan
        self.reset(initial_thrust)

    @classmethod
    def hovering(cls, params: QuadrotorParams) -> MotorModel:
        """Motors already spinning at hover thrust."""
        return cls(params, params.hover_thrust)

    def reset(self, thrust: npt.ArrayLike = 0.0) -> None:
        """Set the actual thrust of every rotor [N] (scalar or 4 values)."""
        self._thrust = self._clip(thrust)

    def step(self, commanded: npt.ArrayLike, dt: float) -> FloatArray:
        """Advance by ``dt`` seconds under ``commanded`` thrusts [N]; returns actual thrusts."""
        self.step_values(commanded, dt)
        return self.thrust

    def step_values(self, commanded: npt.ArrayLike,
                    dt: float) -> tuple[float, float, float, float]:
        """:meth:`step`, returning the four actual thrusts [N] as floats."""
        if dt != self._dt:
            if dt < 0.0:
                raise ValueError(f"dt: {dt} s must be >= 0")
            self._dt, self._alpha = dt, -math.expm1(-dt / self._tau)
        alpha = self._alpha
        # the four rotors written out: quicker than a loop, in the same arithmetic
        (t0, t1, t2, t3), (c0, c1, c2, c3) = self._thrust, self._clip(commanded)
        thrust = self._thrust = (t0 + alpha * (c0 - t0), t1 + alpha * (c1 - t1),
                                 t2 + alpha * (c2 - t2), t3 + alpha * (c3 - t3))
        return thrust

    @property
    def thrust(self) -> FloatArray:
        """Actual rotor thrusts [N] (a new array)."""
        return np.array(self._thrust)

    @property
    def rotor_speed(self) -> FloatArray:
        """Rotor speeds [rad/s], from ``thrust = kf * omega^2``."""
        result: FloatArray = np.sqrt(self.thrust / self._kf)
        return result

    def _clip(self, thrust: npt.ArrayLike) -> tuple[float, float, float, float]:
        """``thrust`` (scalar or 4 values) within ``[0, max_motor_thrust]``, as floats."""
        values = np.asarray(thrust, dtype=np.float64)
        if values.shape != (NUM_ROTORS,):
            values = np.broadcast_to(values, (NUM_ROTORS,))
        high = self._max
        c0, c1, c2, c3 = values.tolist()
        # NaN stays NaN, as in np.clip; conditionals are quicker here than min and max
        return (0.0 if c0 < 0.0 else high if c0 > high else c0,
                0.0 if c1 < 0.0 else high if c1 > high else c1,
                0.0 if c2 < 0.0 else high if c2 > high else c2,
                0.0 if c3 < 0.0 else high if c3 > high else c3)


@dataclass(frozen=True)
class ImuNoiseParams:
    """Continuous-time IMU noise (Allan-variance style), roughly a Pixhawk-class ICM-20689.

    White noise densities, bias random walks and the standard deviation of the turn-on
    bias, for the accelerometer [m/s^2] and the gyroscope [rad/s].
    """

    accel_noise_density: float = 2.0e-3  # m/s^2/sqrt(Hz)
    accel_bias_random_walk: float = 3.0e-3  # m/s^3/sqrt(Hz)
    accel_bias_initial_std: float = 0.05  # m/s^2
    gyro_noise_density: float = 1.7e-4  # rad/s/sqrt(Hz)
    gyro_bias_random_walk: float = 2.0e-5  # rad/s^2/sqrt(Hz)
    gyro_bias_initial_std: float = 5.0e-3  # rad/s

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ParameterError(f"ImuNoiseParams.{f.name}: {value!r} must be >= 0")

    @classmethod
    def noiseless(cls) -> ImuNoiseParams:
        """All zeros: the IMU reads the simulator's truth (null object)."""
        return cls(*(0.0 for _ in fields(cls)))


ImuValues = tuple[float, float, float, float, float, float]
"""An IMU sample as floats: specific force (x, y, z) [m/s^2], then angular rate [rad/s]."""


class ImuSample(NamedTuple):
    """Body-frame specific force [m/s^2] and angular rate [rad/s] (FLU)."""

    accel: FloatArray
    gyro: FloatArray

    @classmethod
    def of(cls, values: Sequence[float]) -> ImuSample:
        """From six floats, specific force then angular rate (:data:`ImuValues`): two views
        of one new array."""
        both = np.array(values, dtype=np.float64)
        return cls(both[:3], both[3:])


class ImuNoiseModel:
    """Adds white noise and a random-walk bias to true IMU readings; seeded, reproducible.

    Discretised per sample of period ``dt``: white noise std ``density / sqrt(dt)``, bias
    step std ``random_walk * sqrt(dt)``.

    The model owns ``rng``: it draws the turn-on biases at once, then the standard normals
    of ``block`` samples at a time (numpy fills an array in the order single draws would
    come, so the noise is the same whatever the block). For the samples still to come in
    the block it works out, in numpy and at once, the bias after each (a running sum:
    ``np.add.accumulate`` adds in order, as one sample at a time would) and the white
    noise, with the arithmetic of the per-sample formulas (order included), so the same
    numbers; a sample then only adds them to the truth, on Python floats. A change of
    period works them out again from that sample on. Another user of the same generator
    would see its draws moved.
    """

    def __init__(self, params: ImuNoiseParams, rng: np.random.Generator,
                 block: int = 512) -> None:
        if block < 1:
            raise ValueError(f"block: {block} samples must be >= 1")
        self._params = params
        self._rng = rng
        self._block = block
        accel_bias = rng.normal(0.0, params.accel_bias_initial_std, 3)
        gyro_bias = rng.normal(0.0, params.gyro_bias_initial_std, 3)
        self._bias: list[float] = [*accel_bias.tolist(), *gyro_bias.tolist()]  # accel, gyro
        self._walks = np.repeat([params.accel_bias_random_walk,
                                 params.gyro_bias_random_walk], 3)
        self._densities = np.repeat([params.accel_noise_density, params.gyro_noise_density], 3)
        # the block's standard normals, 12 a sample: bias walks (accel, gyro), then white
        # noise (accel, gyro), the order of the four rng.normal(0, std, 3) calls they replaced
        self._normals = np.empty((0, 12))
        self._next = 0  # the block's next sample
        # from sample _planned_from of the block on, for sample period _dt: the bias after
        # each sample and its white noise, six values a sample, flat
        self._dt = math.nan
        self._planned_from = 0
        self._bias_after: list[float] = []
        self._white: list[float] = []

    @property
    def accel_bias(self) -> FloatArray:
        """Current accelerometer bias [m/s^2]."""
        return np.array(self._bias[:3])

    @property
    def gyro_bias(self) -> FloatArray:
        """Current gyroscope bias [rad/s]."""
        return np.array(self._bias[3:])

    def sample(self, accel: npt.ArrayLike, gyro: npt.ArrayLike, dt: float) -> ImuSample:
        """A noisy reading of the true ``accel`` and ``gyro``; ``dt`` is the sample period [s]."""
        ax, ay, az = np.asarray(accel, dtype=np.float64).tolist()
        gx, gy, gz = np.asarray(gyro, dtype=np.float64).tolist()
        return ImuSample.of(self.noisy_values((ax, ay, az, gx, gy, gz), dt))

    def noisy_values(self, truth: Sequence[float], dt: float) -> ImuValues:
        """:meth:`sample` on floats: the six true values, specific force then angular rate
        (what :attr:`sim.scene.SceneViews.imu` holds), in and out."""
        if dt != self._dt and dt <= 0.0:
            raise ValueError(f"dt: {dt} s must be > 0")
        k = self._next
        if k == len(self._normals):
            self._normals = self._rng.standard_normal((self._block, 12))
            k = 0
            self._plan(0, dt)
        elif dt != self._dt:
            self._plan(k, dt)
        self._next = k + 1
        i = 6 * (k - self._planned_from)
        b = self._bias = self._bias_after[i : i + 6]
        w = self._white[i : i + 6]
        ax, ay, az, gx, gy, gz = truth
        return (ax + b[0] + w[0], ay + b[1] + w[1], az + b[2] + w[2],
                gx + b[3] + w[3], gy + b[4] + w[4], gz + b[5] + w[5])

    def _plan(self, first: int, dt: float) -> None:
        """The bias after each sample of the block from ``first`` on, and their white
        noise, for sample period ``dt``: per sample and axis ``bias + z * walk * sqrt(dt)``
        and ``z * (density * (1 / sqrt(dt)))``, as the per-sample formulas round."""
        sqrt_dt = math.sqrt(dt)
        z = self._normals[first:]
        steps = z[:, :6] * self._walks * sqrt_dt
        bias_after = np.add.accumulate(np.vstack((self._bias, steps)), axis=0)[1:]
        white = z[:, 6:] * (self._densities * (1.0 / sqrt_dt))
        self._dt = dt
        self._planned_from = first
        self._bias_after = bias_after.ravel().tolist()
        self._white = white.ravel().tolist()
