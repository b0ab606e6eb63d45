"""The simulated PX4-style firmware: modules declared as data, run by the static scheduler.

:data:`FIRMWARE_MODULES` is the whole firmware as a table a reviewer can check against
PX4: each module's task group, dependencies, what it provides, and its periodic
functions with their rates. :func:`~sim.fcu.scheduler.resolve` orders them (seed 002,
Algorithms 1-2) and places each function on the main loop (default 500 Hz) with a
prescaler and an offset; :class:`Firmware` binds the names to its methods and runs one
main-loop tick per :meth:`Firmware.tick`, on the FCU's own clock.

Frames and units on this side are PX4's: NED world, FRD body, microseconds on the FCU
clock. The firmware talks to the companion only through :class:`~sim.fcu.agent.FcuAgentNode`
(uORB topics out, ``/fmu/in`` messages in), and to the simulator only through the IMU
it reads and the motor thrusts it commands.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt

import interfaces
from interfaces.px4 import (
    FCU_COMPONENT_ID,
    FCU_SYSTEM_ID,
    MAV_TYPE_QUADROTOR,
    ODOMETRY_QUALITY_BEST,
    ArmingState,
    BatteryWarning,
    NavigationState,
    PoseFrame,
    VehicleType,
    VelocityFrame,
)
from interfaces.px4.timesync import Px4Timesync, ns_to_us
from runtime.parameters import load_parameters, param, validate_parameters
from sim.fcu.agent import AGENT_IN, Arrival, FcuAgentNode
from sim.fcu.battery import (
    BATTERY_NODE_NAME,
    BatteryEstimator,
    BatteryModel,
    BatteryParams,
    BatteryStatusData,
)
from sim.fcu.clock import FcuClock
from sim.fcu.commander import (
    COMMANDER_NODE_NAME,
    Commander,
    CommanderInputs,
    CommanderParams,
    CommanderStatus,
    VehicleCommandAckData,
    VehicleCommandData,
)
from sim.fcu.control import (
    CONTROL_NODE_NAME,
    AttitudeController,
    ControlGains,
    Mixer,
    PositionController,
    PositionControlOutput,
    Quat,
    RateController,
    TrajectorySetpointData,
    Vec3,
    quat_yaw,
)
from sim.fcu.errors import ModuleSpecError
from sim.fcu.estimator import (
    ESTIMATOR_NODE_NAME,
    Estimator,
    EstimatorOutput,
    EstimatorParams,
    VisionSample,
)
from sim.fcu.gyro_calibration import GyroCalibration
from sim.fcu.land_detector import (
    LAND_DETECTOR_NODE_NAME,
    LandDetectedData,
    LandDetector,
    LandDetectorInputs,
    LandDetectorParams,
)
from sim.fcu.modules import ModuleSpec, PeriodicSpec, TaskGroup
from sim.fcu.scheduler import DEFAULT_MAIN_FREQ_HZ, ResolvedSchedule, Scheduler, resolve
from sim.quadrotor import GRAVITY, NUM_ROTORS, QuadrotorParams
from sim.world import Imu, Scene

TIMESYNC_MSG = "quadmission_interfaces/msg/Timesync"  # the modelled XRCE session sync

FloatArray = npt.NDArray[np.float64]

FIRMWARE_NODE_NAME = "fcu_firmware"
"""The firmware's section in its ROS 2 parameter file, ``config/fcu_firmware.yaml``."""


@dataclass(frozen=True)
class FirmwareParams:
    """What the firmware's modules share (``config/fcu_firmware.yaml``); ranges declared once."""

    imu_rate_hz: float = param(unit="Hz", range=(1.0, 8000.0))
    """IMU samples the firmware reads (one per main-loop tick at 500 Hz)."""
    land_speed: float = param(unit="m/s", range=(0.1, 5.0))
    """Auto-land descent speed (PX4 ``MPC_LAND_SPEED``)."""
    land_crawl_speed: float = param(unit="m/s", range=(0.05, 5.0))
    """Descent speed below ``land_crawl_height``."""
    land_crawl_height: float = param(unit="m", range=(0.0, 20.0))
    """Height above home below which the landing descent slows to ``land_crawl_speed``."""
    descend_acceleration: float = param(unit="m/s^2", range=(0.0, 5.0))
    """DESCEND without a vertical velocity: PX4's FlightTaskDescend commands this downward
    acceleration (thrust below hover, a crash landing). Here the least the descent asks
    for: it speeds up to ``land_speed`` on the dead-reckoned velocity, then on at this
    acceleration (it can neither brake nor climb), landing a little harder than PX4's
    barometer-aided descent at ``land_speed``."""
    idle_thrust_fraction: float = param(unit="of max thrust per motor", range=(0.0, 0.3))
    """Motor thrust while armed on the ground (PX4 spins the motors at idle)."""
    gyro_calibration_s: float = param(unit="s", range=(0.0, 60.0))
    """Disarmed and at rest this long: the mean gyro rate is the estimator's gyro bias
    (PX4's ``gyro_calibration`` module); 0 turns it off."""
    rest_rate: float = param(unit="rad/s", range=(0.0, 1.0))
    """At rest: every gyro rate below this ..."""
    rest_accel: float = param(unit="m/s^2", range=(0.0, 5.0))
    """... and the specific force within this of 1 g."""

    def __post_init__(self) -> None:
        validate_parameters(self)


def _periodic(fun: str, hz: float) -> PeriodicSpec:
    return PeriodicSpec(fun, freq_hz=hz)


#: The firmware, as data. Rates are PX4's (uXRCE-DDS rate limits for the /fmu/out topics).
FIRMWARE_MODULES: tuple[ModuleSpec, ...] = (
    ModuleSpec("imu_driver", group=TaskGroup.SENSORS, provides=("imu",),
               periodics=(_periodic("imu_update", 500),)),
    ModuleSpec("battery_status", group=TaskGroup.SENSORS, provides=("battery",),
               periodics=(_periodic("battery_update", 10),)),
    ModuleSpec("ekf2", group=TaskGroup.ESTIMATION, depends=("imu_driver",),
               provides=("estimator",), periodics=(_periodic("ekf_update", 500),)),
    ModuleSpec("land_detector", group=TaskGroup.ESTIMATION, depends=("@estimator",),
               periodics=(_periodic("land_detector_update", 50),)),
    ModuleSpec("commander", group=TaskGroup.CORE,
               depends=("@estimator", "land_detector", "@battery", "uxrce_dds_client"),
               periodics=(_periodic("commander_update", 100),)),
    ModuleSpec("flight_mode_manager", group=TaskGroup.CONTROL, depends=("commander",),
               periodics=(_periodic("setpoint_update", 100),)),
    ModuleSpec("mc_pos_control", group=TaskGroup.CONTROL,
               depends=("@estimator", "flight_mode_manager"),
               periodics=(_periodic("position_control", 100),)),
    ModuleSpec("mc_att_control", group=TaskGroup.CONTROL, depends=("mc_pos_control",),
               periodics=(_periodic("attitude_control", 250),)),
    ModuleSpec("mc_rate_control", group=TaskGroup.CONTROL, depends=("mc_att_control",),
               periodics=(_periodic("rate_control", 500),)),
    ModuleSpec("control_allocator", group=TaskGroup.ACTUATORS, depends=("mc_rate_control",),
               provides=("motors",), periodics=(_periodic("allocate", 500),)),
    ModuleSpec("uxrce_dds_client", group=TaskGroup.DATALINK, provides=("datalink",),
               periodics=(_periodic("dds_receive", 500), _periodic("timesync_request", 10))),
    ModuleSpec("telemetry", group=TaskGroup.TELEMETRY, depends=("uxrce_dds_client", "@estimator"),
               periodics=(
                   _periodic("pub_vehicle_odometry", 100),
                   _periodic("pub_vehicle_local_position", 50),
                   _periodic("pub_vehicle_attitude", 50),
                   _periodic("pub_vehicle_status", 5),
                   _periodic("pub_battery_status", 1),
                   _periodic("pub_timesync_status", 10),
                   _periodic("pub_vehicle_land_detected", 5),
                   _periodic("pub_failsafe_flags", 5),
                   _periodic("pub_sensor_combined", 100),
               )),
)


def firmware_modules(rates_hz: Mapping[str, float] | None = None) -> tuple[ModuleSpec, ...]:
    """:data:`FIRMWARE_MODULES` with some periodic functions at other rates.

    ``rates_hz`` maps a periodic function's name to its rate [Hz], e.g.
    ``{"pub_sensor_combined": 200.0}``; the others keep the table's rate. A name the table
    does not declare raises ModuleSpecError. Whether the main loop can realise a rate is
    checked when the schedule is resolved (RateError).
    """
    rates = dict(rates_hz or {})
    declared = {p.fun for m in FIRMWARE_MODULES for p in m.periodics}
    for fun in rates:
        if fun not in declared:
            raise ModuleSpecError(
                f"rates_hz.{fun}", f"no such periodic function; declared: {sorted(declared)}")
    if not rates:
        return FIRMWARE_MODULES
    return tuple(
        replace(m, periodics=tuple(
            replace(p, freq_hz=rates[p.fun], period_s=None) if p.fun in rates else p
            for p in m.periodics))
        for m in FIRMWARE_MODULES
    )


@dataclass(frozen=True)
class ConsumedVision:
    """An external-vision sample as the FCU's estimator consumed it (FCU clock, us)."""

    timestamp_us: int  # the message's ``timestamp``
    timestamp_sample_us: int  # the message's ``timestamp_sample``
    consumed_us: int  # FCU clock when the estimator took it (dds_receive tick, or arrival)


@dataclass
class FirmwareConfig:
    """Everything a :class:`Firmware` is built from (the YAMLs under config/fcu_*).

    ``rates_hz`` overrides periodic-function rates of :data:`FIRMWARE_MODULES` by function
    name [Hz] (see :func:`firmware_modules`); empty keeps the table's rates.
    ``event_driven_inputs`` names ``/fmu/in`` topics the firmware handles the moment they
    arrive, between main-loop ticks (seed 000's event-driven bridge), instead of at its
    500 Hz ``dds_receive`` poll; empty (the default) polls every input, as PX4 does.
    """

    quad: QuadrotorParams = field(default_factory=QuadrotorParams)
    firmware: FirmwareParams | None = None
    land_detector: LandDetectorParams | None = None
    control: ControlGains | None = None
    estimator: EstimatorParams | None = None
    commander: CommanderParams | None = None
    battery: BatteryParams | None = None
    main_freq_hz: int = DEFAULT_MAIN_FREQ_HZ
    offsets: str = "balanced"
    rates_hz: Mapping[str, float] = field(default_factory=dict)
    event_driven_inputs: frozenset[str] = frozenset()

    def resolved(self) -> FirmwareConfig:
        """This configuration with every module's parameters not given read from config/."""
        return replace(
            self,
            firmware=self.firmware or load_parameters(FirmwareParams, FIRMWARE_NODE_NAME),
            land_detector=self.land_detector
            or load_parameters(LandDetectorParams, LAND_DETECTOR_NODE_NAME),
            control=self.control or load_parameters(ControlGains, CONTROL_NODE_NAME),
            estimator=self.estimator or load_parameters(EstimatorParams, ESTIMATOR_NODE_NAME),
            commander=self.commander or load_parameters(CommanderParams, COMMANDER_NODE_NAME),
            battery=self.battery or load_parameters(BatteryParams, BATTERY_NODE_NAME),
        )


def firmware_schedule(main_freq_hz: int = DEFAULT_MAIN_FREQ_HZ,
                      offsets: str = "balanced",
                      rates_hz: Mapping[str, float] | None = None) -> ResolvedSchedule:
    """The resolved firmware: module order, prescalers and offsets."""
    return resolve(firmware_modules(rates_hz), main_freq_hz=main_freq_hz, offsets=offsets)


def _f32(values: FloatArray | Sequence[float]) -> npt.NDArray[np.float32]:
    """A vector as px4_msgs carries it (float32, a copy)."""
    return np.array(values, dtype=np.float32)


_ORIENTATION_VARIANCE = np.full(3, 1e-4, dtype=np.float32)  # rad^2, VehicleOdometry's


def _flu_to_frd(v: Sequence[float]) -> Vec3:
    x, y, z = v
    return (x, -y, -z)  # a pi rotation about x: y and z negated, exactly


class Firmware:
    """The flight controller: call :meth:`tick` once per main-loop period (a world part).

    It also serves as the world's motor-command source (:meth:`commands`).
    """

    name = "fcu"

    def __init__(self, agent: FcuAgentNode, imu: Imu, clock: FcuClock,
                 config: FirmwareConfig | None = None) -> None:
        cfg = (config or FirmwareConfig()).resolved()
        assert cfg.control and cfg.estimator and cfg.commander and cfg.battery
        assert cfg.firmware and cfg.land_detector
        self.params = cfg.firmware
        self.config = cfg
        self.rate_hz = float(cfg.main_freq_hz)
        self.agent = agent
        self.imu = imu
        self.clock = clock
        self.quad = cfg.quad
        self.schedule = firmware_schedule(cfg.main_freq_hz, cfg.offsets, cfg.rates_hz)
        self.position_controller = PositionController(cfg.control, cfg.quad)
        self.attitude_controller = AttitudeController(cfg.control)
        self.rate_controller = RateController(cfg.control, cfg.quad)
        self.mixer = Mixer(cfg.quad)
        self.estimator = Estimator(cfg.estimator)
        self.gyro_calibration = GyroCalibration(
            round(self.params.gyro_calibration_s * 1_000_000), self.params.rest_rate,
            self.params.rest_accel)
        self.commander = Commander(cfg.commander)
        self.land_detector = LandDetector(
            cfg.land_detector,
            thrust_min=cfg.control.thrust_min_fraction,
            thrust_hover=cfg.quad.hover_thrust / cfg.quad.max_motor_thrust,
        )
        self.battery_model = BatteryModel(cfg.battery.model)
        self.battery_estimator = BatteryEstimator(
            cfg.battery.estimator, cfg.battery.model.cell_count, cfg.battery.model.capacity_mah
        )
        self.timesync = Px4Timesync()
        self._dt_us = 1_000_000 // cfg.main_freq_hz
        self._period_us = {p.fun: p.prescaler * self._dt_us for p in self.schedule.periodics}
        self._rate_period_us = self._period_us["rate_control"]
        self._position_period_us = self._period_us["position_control"]
        self._now_ns = 0
        self._now_us = 0
        # the firmware's uORB: latest values of everything
        self.accel_frd: Vec3 = (0.0, 0.0, -GRAVITY)
        self.gyro_frd: Vec3 = (0.0, 0.0, 0.0)
        self.imu_time_us = 0
        self._estimate: EstimatorOutput | None = None
        self._estimate_stale = False  # predicted since the estimate was last built
        self.status: CommanderStatus | None = None
        self._armed = False  # status.arming_state is ARMED (read at 500 Hz)
        self.land: LandDetectedData | None = None
        self.battery: BatteryStatusData | None = None
        self.offboard_heartbeat_us: int | None = None
        self.offboard_setpoint: TrajectorySetpointData | None = None
        self.pending_commands: list[VehicleCommandData] = []
        self.setpoint = TrajectorySetpointData()
        self.position_out: PositionControlOutput | None = None
        self.rate_setpoint: Vec3 = (0.0, 0.0, 0.0)
        self.torque_setpoint: Vec3 = (0.0, 0.0, 0.0)
        self.motor_commands = np.zeros(NUM_ROTORS)
        # the commands while not flying: armed, the motors idle; disarmed, stopped (shared
        # from tick to tick, so read-only)
        self._idle_commands = np.full(
            NUM_ROTORS, self.params.idle_thrust_fraction * self.quad.max_motor_thrust)
        self._stopped_commands = np.zeros(NUM_ROTORS)
        self._idle_commands.setflags(write=False)
        self._stopped_commands.setflags(write=False)
        self._hold_position: FloatArray | None = None
        self._hold_yaw = 0.0
        self._mode_of_hold: NavigationState | None = None
        self._last_nav_state: NavigationState | None = None
        self._armed_before = False
        self._timesync_seq = 0
        self._last_timesync_status: Any = None
        self._last_agent_us = 0
        self.acks: list[VehicleCommandAckData] = []
        # called with every external-vision sample the estimator consumes (evaluation)
        self.vision_observers: list[Callable[[ConsumedVision], None]] = []
        functions = {
            "imu_update": self.imu_update,
            "battery_update": self.battery_update,
            "ekf_update": self.ekf_update,
            "land_detector_update": self.land_detector_update,
            "commander_update": self.commander_update,
            "setpoint_update": self.setpoint_update,
            "position_control": self.position_control,
            "attitude_control": self.attitude_control,
            "rate_control": self.rate_control,
            "allocate": self.allocate,
            "dds_receive": self.dds_receive,
            "timesync_request": self.timesync_request,
            **{f"pub_{topic}": self._publisher(topic) for topic in (
                "vehicle_odometry", "vehicle_local_position", "vehicle_attitude",
                "vehicle_status", "battery_status", "timesync_status",
                "vehicle_land_detected", "failsafe_flags", "sensor_combined")},
        }
        # the handler of each /fmu/in topic (and the session's timesync requests)
        self._handlers: dict[str, Callable[[Any], None]] = {
            topic: getattr(self, f"_on_{topic}") for topic in AGENT_IN}
        self.scheduler = Scheduler(self.schedule, functions, clock=self)
        self.scheduler.init()
        for topic in sorted(cfg.event_driven_inputs):
            agent.on_arrival(topic, self._consume_on_arrival)

    # -- the scheduler's clock and the world part -------------------------------------------
    def now_us(self) -> int:
        return self._now_us

    def update(self, t_ns: int, scene: Scene) -> None:
        """One main-loop tick at simulated time ``t_ns`` (the world calls this)."""
        self.tick(t_ns)

    def tick(self, t_ns: int) -> None:
        self._now_ns = t_ns
        self._now_us = self.clock.fcu_time_us(t_ns)
        self.scheduler.tick()

    def commands(self, t_ns: int, scene: Scene) -> FloatArray:
        """Commanded rotor thrusts [N] (the world's MotorCommands)."""
        return self.motor_commands

    @property
    def estimate(self) -> EstimatorOutput | None:
        """The estimator's output as of the last ``ekf_update`` (built when first read:
        most ticks read only part of it, some none)."""
        if self._estimate_stale:
            self._estimate = self.estimator.output()
            self._estimate_stale = False
        return self._estimate

    # The controllers, the land detector and the commander read a few numbers of the
    # estimate at 50-250 Hz: they take them from the filter while the estimate is stale (the
    # filter has not changed since the last ekf_update: a vision fusion builds the estimate
    # first), not from a built estimate (telemetry builds it).

    def _attitude(self) -> Quat:
        """``estimate.state.q`` as floats."""
        if self._estimate_stale:
            return self.estimator.attitude()
        assert self._estimate is not None
        w, x, y, z = self._estimate.state.q.tolist()
        return (w, x, y, z)

    def _kinematics(self) -> tuple[Vec3, Vec3, Quat, Vec3]:
        """``estimate.state`` as floats: position, velocity, q, angular velocity."""
        if self._estimate_stale:
            return self.estimator.kinematics()
        assert self._estimate is not None
        s = self._estimate.state
        n, e, d = s.position_ned.tolist()
        vn, ve, vd = s.velocity_ned.tolist()
        w, x, y, z = s.q.tolist()
        p, q, r = s.angular_velocity_frd.tolist()
        return (n, e, d), (vn, ve, vd), (w, x, y, z), (p, q, r)

    def _position_valid(self) -> bool:
        """``estimate.position_valid``."""
        if self._estimate_stale:
            return self.estimator.position_valid()
        assert self._estimate is not None
        return self._estimate.position_valid

    def _has_estimate(self) -> bool:
        """``estimate is not None`` without building it."""
        return self._estimate_stale or self._estimate is not None

    @property
    def armed(self) -> bool:
        return self._armed

    @property
    def nav_state(self) -> NavigationState:
        return self.status.nav_state if self.status else NavigationState.AUTO_LOITER

    # -- sensors ------------------------------------------------------------------------
    def imu_update(self) -> None:
        values = self.imu.latest_values  # the six floats (no ImuSample arrays built)
        if values is None:
            return
        self.accel_frd = _flu_to_frd(values[:3])
        self.gyro_frd = _flu_to_frd(values[3:])
        self.imu_time_us = self._now_us

    def battery_update(self) -> None:
        measurement = self.battery_model.step(self._period_us["battery_update"],
                                              self.motor_commands.tolist())
        self.battery = self.battery_estimator.update(measurement, self.armed)

    # -- estimation ---------------------------------------------------------------------
    def ekf_update(self) -> None:
        if self.imu.latest_values is None:
            return
        if not self._has_estimate():  # boot: start the filter one tick before the first sample
            self.estimator.reset(self._now_us - self._dt_us)
        self.estimator.predict(self._now_us, self.accel_frd, self.gyro_frd)
        bias = self.gyro_calibration.update(self._now_us, self.gyro_frd, self.accel_frd,
                                            self._armed)
        if bias is not None:
            self.estimator.set_gyro_bias(bias)
        self._estimate_stale = True

    def land_detector_update(self) -> None:
        if not self._has_estimate():
            return
        _, (vx, vy, vz), _, (roll_rate, pitch_rate, _) = self._kinematics()
        valid = self._position_valid()
        ax, ay, az = self.accel_frd
        # floats, not numpy reductions, on 3 and 4 values: the same sums, bit for bit
        # (written out: Python 3.12's sum() compensates, numpy's does not)
        c0, c1, c2, c3 = self.motor_commands.tolist()
        collective = c0 + c1 + c2 + c3
        self.land = self.land_detector.update(LandDetectorInputs(
            now_us=self._now_us,
            armed=self.armed,
            thrust=collective / (NUM_ROTORS * self.quad.max_motor_thrust),
            vx=vx, vy=vy, vz=vz,
            v_xy_valid=valid, v_z_valid=valid,
            roll_rate=roll_rate, pitch_rate=pitch_rate,
            specific_force_norm=math.sqrt(ax * ax + ay * ay + az * az),
            climb_rate_control=True,
            vz_setpoint=float(self.setpoint.velocity[2]) if math.isfinite(
                self.setpoint.velocity[2]) else math.nan,
        ))

    # -- commander and setpoints ----------------------------------------------------------
    def commander_update(self) -> None:
        has_estimate = self._has_estimate()
        valid, altitude, eph = False, math.nan, math.inf
        if has_estimate:
            valid = self._position_valid()
            altitude = -self._kinematics()[0][2]  # altitude is -z (NED)
            eph = self.estimator.eph()
        out = self.commander.step(CommanderInputs(
            now_us=self._now_us,
            offboard_heartbeat_us=self.offboard_heartbeat_us,
            landed=self.land.landed if self.land else True,
            battery_warning=self.battery_warning(),
            attitude_valid=has_estimate,
            position_valid=valid,
            position_eph_m=eph,
            altitude_amsl_m=altitude,
            commands=tuple(self.pending_commands),
        ))
        self.pending_commands.clear()
        self.status = out.status
        self._armed = out.status.arming_state is ArmingState.ARMED
        for ack in out.acks:
            self.acks.append(ack)
            self.agent.send("vehicle_command_ack", self._ack_msg(ack), self._now_ns)
        if self._armed and not self._armed_before:
            self.position_controller.reset()
            self.rate_controller.reset()
        self._armed_before = self._armed

    def battery_warning(self) -> BatteryWarning:
        return self.battery.warning if self.battery else BatteryWarning.NONE

    def _hold_here(self, mode: NavigationState) -> FloatArray:
        """The position captured on entering ``mode`` (hold, land, takeoff)."""
        if self._mode_of_hold is not mode or self._hold_position is None:
            assert self.estimate is not None
            self._hold_position = self.estimate.state.position_ned.copy()
            self._hold_yaw = quat_yaw(self.estimate.state.q)
            self._mode_of_hold = mode
        return self._hold_position

    def setpoint_update(self) -> None:
        """PX4's flight mode manager: the trajectory setpoint of the current mode."""
        if not self._has_estimate() or not self._armed:
            self._mode_of_hold = None
            return
        mode = self.nav_state
        if mode is not self._last_nav_state:  # a new mode holds where it is entered
            self._mode_of_hold = None
            self._last_nav_state = mode
        if mode is NavigationState.OFFBOARD and self.offboard_setpoint is not None:
            self.setpoint = self.offboard_setpoint
            self._mode_of_hold = None  # the companion's setpoint is in use
        elif mode is NavigationState.AUTO_TAKEOFF and self.status and self.status.takeoff_target:
            start = self._hold_here(mode)
            z = -self.status.takeoff_target.altitude_amsl_m  # altitude is -z (NED)
            self.setpoint = TrajectorySetpointData(position=np.array([start[0], start[1], z]),
                                                   yaw=self._hold_yaw)
        elif mode in (NavigationState.AUTO_LAND, NavigationState.AUTO_RTL):
            here = self._hold_here(mode)
            est = self.estimate
            assert est is not None
            height = -float(est.state.position_ned[2])
            p = self.params
            speed = p.land_crawl_speed if height < p.land_crawl_height else p.land_speed
            self.setpoint = TrajectorySetpointData(
                position=np.array([here[0], here[1], math.nan]),
                velocity=np.array([math.nan, math.nan, speed]), yaw=self._hold_yaw)
        elif mode is NavigationState.DESCEND:
            # PX4's FlightTaskDescend: level (no horizontal acceleration, so no position
            # needed) and down at MPC_LAND_SPEED on the vertical velocity. PX4 has it from
            # the barometer-aided estimate, and without one descends at a fixed 0.3 m/s^2
            # (thrust below hover). This FCU has no barometer: it descends on the IMU-
            # propagated vertical velocity its filter keeps without vision, its thrust never
            # above PX4's fixed descent's (position_control), so past the land speed it
            # speeds up at that 0.3 m/s^2: the dead-reckoned velocity drifts, and once, on
            # the floor, the velocity loop wound up on it and lifted the vehicle off into a
            # wall.
            self._hold_here(mode)  # the heading to keep
            self.setpoint = TrajectorySetpointData(
                velocity=np.array([math.nan, math.nan, self.params.land_speed]),
                acceleration=np.array([0.0, 0.0, math.nan]), yaw=self._hold_yaw)
        else:  # hold (AUTO_LOITER) and anything else: stay where we are
            here = self._hold_here(NavigationState.AUTO_LOITER)
            self.setpoint = TrajectorySetpointData(position=here.copy(), yaw=self._hold_yaw)

    # -- control ------------------------------------------------------------------------
    def position_control(self) -> None:
        if not self._has_estimate() or not self._armed:
            return
        dt_us = self._position_period_us
        position, velocity, q, _ = self._kinematics()
        ceiling = self.params.descend_acceleration \
            if self.nav_state is NavigationState.DESCEND else -math.inf
        try:
            self.position_out = self.position_controller.update_floats(
                position, velocity, q, self.setpoint, dt_us, ceiling)
        except ValueError:  # an invalid offboard setpoint: hold instead, as PX4 does
            here = self._hold_here(NavigationState.AUTO_LOITER)
            self.position_out = self.position_controller.update_floats(
                position, velocity, q,
                TrajectorySetpointData(position=here.copy(), yaw=self._hold_yaw), dt_us)

    def attitude_control(self) -> None:
        out = self.position_out
        if out is None or not self._armed:
            return
        w, x, y, z = out.attitude_setpoint.tolist()
        self.rate_setpoint = self.attitude_controller.update_quat(
            self._attitude(), (w, x, y, z), out.yawspeed_feedforward)

    def rate_control(self) -> None:
        if not self._armed or not self._has_estimate():
            return
        landed = self.land.landed if self.land else True
        self.torque_setpoint = self.rate_controller.update_floats(
            self.gyro_frd, self.rate_setpoint, self._rate_period_us, landed)

    def allocate(self) -> None:
        if not self._armed or self.position_out is None:
            self.motor_commands = self._idle_commands if self._armed else self._stopped_commands
            return
        mixer = self.mixer
        mixer.mix(self.position_out.collective_thrust, self.torque_setpoint)
        self.rate_controller.set_saturation_flags(mixer.saturation_flags)
        self.motor_commands = mixer.motor_thrusts

    # -- datalink -----------------------------------------------------------------------
    def dds_receive(self) -> None:
        inbox = self.agent.inbox
        for arrival in inbox.take(self._now_ns):
            self._handle(arrival)
        for reply in inbox.take_timesync(self._now_ns):
            # (t1, t2, t3): our send time, the agent's clock, our receive time [us]
            self.timesync.update(reply.request_fcu_us, ns_to_us(reply.agent_time_ns),
                                 self._now_us)
            self._last_timesync_status = self.timesync.estimate
            self._last_agent_us = ns_to_us(reply.agent_time_ns)

    def _consume_on_arrival(self, arrival: Arrival) -> None:
        """An event-driven input, handled at its delivery time (between ticks): the FCU's
        clock reads that time while it is handled."""
        self._now_ns = arrival.delivery_ns
        self._now_us = self.clock.fcu_time_us(arrival.delivery_ns)
        self._handle(arrival)

    def _handle(self, arrival: Arrival) -> None:
        self._handlers[arrival.topic](arrival.msg)

    def timesync_request(self) -> None:
        self.agent.request_timesync(self._now_us, self._now_ns)

    def _on_offboard_control_mode(self, msg: Any) -> None:
        self.offboard_heartbeat_us = self._now_us

    def _on_trajectory_setpoint(self, msg: Any) -> None:
        self.offboard_setpoint = TrajectorySetpointData(  # (float64 copies of the vectors)
            position=msg.position, velocity=msg.velocity, acceleration=msg.acceleration,
            jerk=msg.jerk, yaw=float(msg.yaw), yawspeed=float(msg.yawspeed))

    def _on_vehicle_command(self, msg: Any) -> None:
        self.pending_commands.append(VehicleCommandData(
            command=int(msg.command), param1=float(msg.param1), param2=float(msg.param2),
            param3=float(msg.param3), param4=float(msg.param4), param5=float(msg.param5),
            param6=float(msg.param6), param7=float(msg.param7),
            target_system=int(msg.target_system), target_component=int(msg.target_component),
            source_system=int(msg.source_system), source_component=int(msg.source_component),
            confirmation=int(msg.confirmation), from_external=bool(msg.from_external),
            timestamp_us=int(msg.timestamp)))

    def _on_vehicle_visual_odometry(self, msg: Any) -> None:
        sample_us = int(msg.timestamp_sample) or self._now_us
        _ = self.estimate  # the estimate of the last ekf_update, from before this fusion
        q = msg.q.astype(np.float64)
        variances = msg.position_variance.tolist()
        # the largest variance that is not NaN, if any is finite (PX4 takes the largest)
        var = max(v for v in variances if not math.isnan(v)) if any(
            map(math.isfinite, variances)) else math.nan
        self.estimator.fuse_vision(VisionSample(
            sample_time_us=sample_us,
            position_ned=msg.position.astype(np.float64),
            q=q if all(map(math.isfinite, q.tolist())) else None,
            position_variance=var))
        if self.vision_observers:
            consumed = ConsumedVision(int(msg.timestamp), int(msg.timestamp_sample), self._now_us)
            for observer in self.vision_observers:
                observer(consumed)

    def _on_timesync(self, msg: Any) -> None:
        """Answer a companion's Timesync request: tc1 = our clock [ns], ts1 echoed."""
        if int(msg.tc1) != 0:
            return
        reply = interfaces.new(TIMESYNC_MSG, timestamp=self._now_us, seq=int(msg.seq),
                               tc1=self._now_us * 1000, ts1=int(msg.ts1))
        self.agent.send("timesync", reply, self._now_ns)

    # -- telemetry ----------------------------------------------------------------------
    def _publisher(self, topic: str) -> Any:
        build = getattr(self, f"_msg_{topic}")
        source = _TELEMETRY_SOURCE[topic]

        def publish() -> None:
            if source is not None and not self._has(source):
                return  # nothing to tell yet
            if self.agent.unread(topic):  # nobody subscribes: the bytes, not the message
                self.agent.send_unread(topic, self._now_ns)
                return
            msg = build()
            if msg is not None:
                self.agent.send(topic, msg, self._now_ns)

        return publish

    def _has(self, source: str) -> bool:
        """The firmware state ``source`` exists (the estimate is not built to tell)."""
        if source == "estimate":
            return self._has_estimate()
        return getattr(self, source) is not None

    def _msg_vehicle_odometry(self) -> Any:
        est = self.estimate
        if est is None:
            return None
        s = est.state
        return interfaces.new(
            "px4_msgs/msg/VehicleOdometry", timestamp=self._now_us, timestamp_sample=est.time_us,
            pose_frame=int(PoseFrame.NED), position=_f32(s.position_ned), q=_f32(s.q),
            velocity_frame=int(VelocityFrame.NED), velocity=_f32(s.velocity_ned),
            angular_velocity=_f32(s.angular_velocity_frd),
            position_variance=_f32(est.position_variance_ned),
            orientation_variance=_ORIENTATION_VARIANCE.copy(),
            velocity_variance=_f32(est.velocity_variance_ned), quality=ODOMETRY_QUALITY_BEST)

    def _msg_vehicle_local_position(self) -> Any:
        est = self.estimate
        if est is None:
            return None
        s, valid = est.state, est.position_valid
        x, y, z = s.position_ned.tolist()
        vx, vy, vz = s.velocity_ned.tolist()
        pvx, pvy, pvz = est.position_variance_ned.tolist()
        vvx, vvy, vvz = est.velocity_variance_ned.tolist()
        ax, ay, az = (self.position_out.acceleration_setpoint_ned.tolist() if self.position_out
                      else (0.0, 0.0, 0.0))
        return interfaces.new(
            "px4_msgs/msg/VehicleLocalPosition", timestamp=self._now_us,
            timestamp_sample=est.time_us, xy_valid=valid, z_valid=valid, v_xy_valid=valid,
            v_z_valid=valid, x=x, y=y, z=z, vx=vx, vy=vy, vz=vz, z_deriv=vz,
            ax=_nan_to_num(ax), ay=_nan_to_num(ay), az=_nan_to_num(az),
            heading=quat_yaw(s.q), heading_good_for_control=True,
            eph=math.sqrt(max(pvx, pvy)), epv=math.sqrt(pvz),
            evh=math.sqrt(max(vvx, vvy)), evv=math.sqrt(vvz),
            dead_reckoning=not valid, vxy_max=math.inf, vz_max=math.inf, hagl_min=math.inf,
            hagl_max_z=math.inf, hagl_max_xy=math.inf, dist_bottom=-z,
            dist_bottom_valid=valid)

    def _msg_vehicle_attitude(self) -> Any:
        if self.estimate is None:
            return None
        return interfaces.new("px4_msgs/msg/VehicleAttitude", timestamp=self._now_us,
                              timestamp_sample=self.estimate.time_us,
                              q=_f32(self.estimate.state.q))

    def _msg_vehicle_status(self) -> Any:
        st = self.status
        if st is None:
            return None
        return interfaces.new(
            "px4_msgs/msg/VehicleStatus", timestamp=self._now_us, armed_time=st.armed_time_us,
            takeoff_time=st.takeoff_time_us, arming_state=int(st.arming_state),
            latest_arming_reason=int(st.latest_arming_reason),
            latest_disarming_reason=int(st.latest_disarming_reason),
            nav_state_timestamp=st.nav_state_timestamp_us,
            nav_state_user_intention=int(st.nav_state_user_intention),
            nav_state=int(st.nav_state), failsafe=st.failsafe,
            vehicle_type=int(VehicleType.ROTARY_WING), system_type=MAV_TYPE_QUADROTOR,
            system_id=self.config.commander.system_id if self.config.commander else FCU_SYSTEM_ID,
            component_id=(self.config.commander.component_id if self.config.commander
                          else FCU_COMPONENT_ID),
            pre_flight_checks_pass=st.pre_flight_checks_pass,
            power_input_valid=True, safety_off=True)

    def _msg_battery_status(self) -> Any:
        b = self.battery
        if b is None:
            return None
        return interfaces.new(
            "px4_msgs/msg/BatteryStatus", timestamp=self._now_us, connected=b.connected,
            voltage_v=b.voltage_v, current_a=b.current_a, current_average_a=b.current_average_a,
            discharged_mah=b.discharged_mah, remaining=b.remaining,
            time_remaining_s=b.time_remaining_s, cell_count=b.cell_count,
            capacity=int(b.capacity_mah), warning=int(self.battery_warning()), id=1,
            temperature=math.nan, scale=1.0)

    def _msg_timesync_status(self) -> Any:
        est = self._last_timesync_status
        if est is None:
            return None
        return interfaces.new(
            "px4_msgs/msg/TimesyncStatus", timestamp=self._now_us, source_protocol=2,
            remote_timestamp=max(0, self._last_agent_us),
            observed_offset=int(est.observed_offset_us),
            estimated_offset=int(est.offset_us),
            round_trip_time=max(0, min(2**32 - 1, int(est.rtt_us))))

    def _msg_vehicle_land_detected(self) -> Any:
        ld = self.land
        if ld is None:
            return None
        return interfaces.new(
            "px4_msgs/msg/VehicleLandDetected", timestamp=self._now_us, freefall=ld.freefall,
            ground_contact=ld.ground_contact, maybe_landed=ld.maybe_landed, landed=ld.landed,
            in_ground_effect=ld.in_ground_effect, in_descend=ld.in_descend,
            has_low_throttle=ld.has_low_throttle, vertical_movement=ld.vertical_movement,
            horizontal_movement=ld.horizontal_movement,
            rotational_movement=ld.rotational_movement,
            close_to_ground_or_skipped_check=ld.close_to_ground_or_skipped_check,
            at_rest=ld.at_rest)

    def _msg_failsafe_flags(self) -> Any:
        st = self.status
        if st is None:
            return None
        est = self.estimate
        invalid = est is None or not est.position_valid
        return interfaces.new(
            "px4_msgs/msg/FailsafeFlags", timestamp=self._now_us,
            offboard_control_signal_lost=st.offboard_control_signal_lost,
            local_position_invalid=invalid, local_velocity_invalid=invalid,
            local_altitude_invalid=invalid, attitude_invalid=est is None,
            battery_warning=int(self.battery_warning()), global_position_invalid=True,
            home_position_invalid=False)

    def _msg_sensor_combined(self) -> Any:
        return interfaces.new(
            "px4_msgs/msg/SensorCombined", timestamp=self.imu_time_us,
            gyro_rad=_f32(self.gyro_frd), gyro_integral_dt=self._dt_us,
            accelerometer_m_s2=_f32(self.accel_frd), accelerometer_integral_dt=self._dt_us)

    def _ack_msg(self, ack: VehicleCommandAckData) -> Any:
        return interfaces.new(
            "px4_msgs/msg/VehicleCommandAck", timestamp=self._now_us, command=int(ack.command),
            result=int(ack.result), result_param1=int(ack.result_param1),
            result_param2=int(ack.result_param2), target_system=int(ack.target_system),
            target_component=int(ack.target_component), from_external=bool(ack.from_external))


_TELEMETRY_SOURCE: dict[str, str | None] = {
    "vehicle_odometry": "estimate", "vehicle_local_position": "estimate",
    "vehicle_attitude": "estimate", "vehicle_status": "status", "failsafe_flags": "status",
    "battery_status": "battery", "timesync_status": "_last_timesync_status",
    "vehicle_land_detected": "land", "sensor_combined": None,
}
"""The firmware state each telemetry message is built from (None: always there); no
message is sent before its state exists."""


def _nan_to_num(value: Any) -> float:
    """``float(np.nan_to_num(value))`` for one number, without numpy's per-call cost."""
    v = float(value)
    if math.isfinite(v):
        return v
    return 0.0 if math.isnan(v) else math.copysign(sys.float_info.max, v)
