"""The flight-control node: the layer that hides PX4 from everything above it (seed 003,
sec. 3.2.2).

Entities (under ``/flight_control/``):

- services ``arm`` and ``disarm`` (quadmission_interfaces/srv/Arm, Disarm): arming
  streams the hold setpoint for ``offboard_stream_s`` (PX4 wants the heartbeat for more
  than 1 s), asks for offboard mode, then arms; every FCU command is retried
  (``command_attempts``, ``command_timeout_s``) on a timeout or a temporary rejection;
- actions ``takeoff``, ``land``, ``reach``, ``turn``: reach and takeoff fly the
  interpolated setpoints of :mod:`flight_control.setpoints` (reached in sequence inside
  a sphere, a carrot at cruise speed between them), with distance-left feedback; land is
  the FCU's NAV_LAND, or an offboard descent at the goal's speed; turn ramps the yaw
  setpoint. Goals are validated in
  :mod:`flight_control.goal_checks` and rejected with the reason. A new motion goal
  preempts the running one (aborted, "preempted"); a cancel holds where the vehicle is;
- ``health`` (HealthReport, 1 Hz) for preflight checks.

While it has control (from arming until the vehicle is disarmed) a timer streams the
current setpoint on ``/fcu/setpoint`` at ``setpoint_rate_hz``: the bridge turns each one
into an OffboardControlMode heartbeat plus a TrajectorySetpoint, so the stream is the
offboard heartbeat, and stopping it makes the FCU fail safe. Idle, the setpoint holds
the last goal's end (or where the vehicle was).

It reads the FCU only through the bridge: ``/fcu/status``, ``/fcu/odometry`` (ENU map
frame, FLU body velocity) and ``/fcu/command_ack``. Parameters:
``config/flight_control.yaml``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum, IntEnum
from typing import Any

import numpy as np

import interfaces
from flight_control.frames import quat_rotate, quat_to_yaw, wrap_pi
from flight_control.goal_checks import (
    FieldBounds,
    GoalError,
    GoalProblem,
    VehicleState,
    check_speed,
    check_takeoff_altitude,
    check_target,
    check_vehicle,
    fmt_m,
)
from flight_control.setpoints import FloatArray, ReachPlan, ReachProgress, yaw_toward
from runtime import (
    ActionServer,
    GoalResponse,
    Node,
    ParameterError,
    Rejection,
    ServerGoalHandle,
    param,
    qos_profile_default,
    qos_profile_sensor_data,
)

ARM = interfaces.get_service("quadmission_interfaces/srv/Arm")
DISARM = interfaces.get_service("quadmission_interfaces/srv/Disarm")
TAKEOFF = interfaces.get_action("quadmission_interfaces/action/Takeoff")
LAND = interfaces.get_action("quadmission_interfaces/action/Land")
REACH = interfaces.get_action("quadmission_interfaces/action/Reach")
TURN = interfaces.get_action("quadmission_interfaces/action/Turn")
MAP_FRAME = "map"
#: Slowest commanded descent the FCU's land detector reads as a landing (its threshold is
#: half of PX4's 0.3 m/s crawl speed).
MIN_LAND_SPEED = 0.2  # m/s


class Px4Command(IntEnum):
    """PX4 ``VEHICLE_CMD_*`` numbers this node sends on /fcu/command."""

    NAV_LAND = 21
    DO_SET_MODE = 176
    COMPONENT_ARM_DISARM = 400


class AckResult(IntEnum):
    """``FcuCommandAck.RESULT_*`` (PX4 ``VEHICLE_CMD_RESULT_*``)."""

    ACCEPTED = 0
    TEMPORARILY_REJECTED = 1
    DENIED = 2
    UNSUPPORTED = 3
    FAILED = 4
    IN_PROGRESS = 5
    CANCELLED = 6


class HealthLevel(IntEnum):
    """``ModuleHealth.LEVEL_*``."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


PX4_MODE_ENABLED = 1.0  # DO_SET_MODE param1: MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
PX4_MAIN_MODE_OFFBOARD = 6.0  # DO_SET_MODE param2
FORCE_MAGIC = 21196.0  # COMPONENT_ARM_DISARM param2: skip the checks


@dataclass(frozen=True)
class FlightControlParams:
    """Parameters of ``flight_control``; values live in ``config/flight_control.yaml``."""

    setpoint_rate_hz: float = param(unit="Hz", range=(5.0, 100.0),
                                    description="setpoint stream = offboard heartbeat")
    health_rate_hz: float = param(unit="Hz", range=(0.1, 10.0),
                                  description="~/health publish rate")
    feedback_rate_hz: float = param(unit="Hz", range=(0.5, 50.0),
                                    description="action feedback rate")
    reach_radius: float = param(unit="m", range=(0.02, 2.0),
                                description="a reach succeeds inside this sphere (goal's 0)")
    waypoint_radius: float = param(unit="m", range=(0.02, 2.0),
                                   description="an intermediate setpoint is reached inside it")
    waypoint_spacing: float = param(unit="m", range=(0.05, 5.0),
                                    description="distance between intermediate setpoints")
    cruise_speed: float = param(unit="m/s", range=(0.1, 5.0),
                                description="reach speed when the goal gives 0")
    max_speed: float = param(unit="m/s", range=(0.1, 5.0),
                             description="faster goals are rejected")
    acceleration: float = param(unit="m/s^2", range=(0.1, 5.0),
                                description="carrot acceleration and braking")
    stop_speed: float = param(unit="m/s", range=(0.01, 1.0),
                              description="stopped at a target below this speed")
    settle_s: float = param(unit="s", range=(0.0, 5.0),
                            description="inside the radius and stopped this long = reached")
    takeoff_altitude: float = param(unit="m", range=(0.3, 10.0),
                                    description="takeoff altitude when the goal gives 0")
    takeoff_speed: float = param(unit="m/s", range=(0.1, 3.0),
                                 description="climb speed when the goal gives 0")
    yaw_rate: float = param(unit="rad/s", range=(0.05, 3.0),
                            description="turn rate when the goal gives 0")
    max_yaw_rate: float = param(unit="rad/s", range=(0.05, 3.0),
                                description="faster turn goals are rejected")
    yaw_tolerance: float = param(unit="rad", range=(0.005, 0.5),
                                 description="a turn succeeds within this angle")
    command_attempts: int = param(range=(1, 20), description="sends of one FCU command")
    command_timeout_s: float = param(unit="s", range=(0.05, 10.0),
                                     description="wait for an ack before sending again")
    offboard_stream_s: float = param(unit="s", range=(1.05, 10.0),
                                     description="stream before asking for offboard (PX4: >1 s)")
    status_timeout_s: float = param(unit="s", range=(0.1, 10.0),
                                    description="no /fcu/status this long = FCU disconnected")
    field_min: tuple[float, ...] = param(unit="m", range=(-1000.0, 1000.0),
                                         description="allowed volume, lower corner x, y, z")
    field_max: tuple[float, ...] = param(unit="m", range=(-1000.0, 1000.0),
                                         description="allowed volume, upper corner x, y, z")
    min_altitude: float = param(unit="m", range=(0.0, 100.0),
                                description="floor: lowest reach target (map z)")
    battery_critical_warning: int = param(range=(1, 3),
                                          description="px4 WARNING_* that rejects goals")
    timeout_factor: float = param(range=(1.0, 10.0),
                                  description="goal timeout = factor * expected + margin")
    timeout_margin_s: float = param(unit="s", range=(0.0, 120.0),
                                    description="goal timeout = factor * expected + margin")
    land_timeout_s: float = param(unit="s", range=(1.0, 300.0),
                                  description="touchdown and disarm within this time")

    def __post_init__(self) -> None:
        try:
            self.bounds()
        except ValueError as exc:
            raise ParameterError(f"flight_control.field_min/field_max: {exc}") from None
        for name, limit in (("cruise_speed", "max_speed"), ("takeoff_speed", "max_speed"),
                            ("yaw_rate", "max_yaw_rate")):
            if getattr(self, name) > getattr(self, limit):
                raise ParameterError(f"flight_control.{name}: {getattr(self, name)} is above "
                                     f"{limit} {getattr(self, limit)}")

    def bounds(self) -> FieldBounds:
        return FieldBounds.of(self.field_min, self.field_max)


@dataclass(frozen=True)
class CommandOutcome:
    """How an FCU command ended: accepted or not, the last ack's result (None: no ack)."""

    command: int
    accepted: bool
    result: int | None
    attempts: int

    @property
    def timed_out(self) -> bool:
        return self.result is None

    def describe(self) -> str:
        known = {int(c) for c in Px4Command}
        name = Px4Command(self.command).name if self.command in known else str(self.command)
        if self.accepted:
            return f"{name} accepted"
        if self.result is None:
            return f"{name}: no ack from the FCU after {self.attempts} attempt(s)"
        return f"{name} refused by the FCU: {AckResult(self.result).name}"


@dataclass(frozen=True)
class Setpoint:
    """What the stream sends: position [m], velocity feed-forward [m/s], yaw [rad]."""

    position: FloatArray
    velocity: FloatArray
    yaw: float


class Ending(Enum):
    """How a followed plan or a turn ended."""

    REACHED = "reached"
    CANCELED = "canceled"
    PREEMPTED = "preempted"
    TIMEOUT = "timeout"
    LOST_CONTROL = "lost_control"


def _point(p: FloatArray) -> Any:
    return interfaces.new("geometry_msgs/msg/Point", x=float(p[0]), y=float(p[1]),
                          z=float(p[2]))


def _vector(v: FloatArray) -> Any:
    return interfaces.new("geometry_msgs/msg/Vector3", x=float(v[0]), y=float(v[1]),
                          z=float(v[2]))


def _xyz(p: FloatArray) -> str:
    return f"({fmt_m(float(p[0]))}, {fmt_m(float(p[1]))}, {fmt_m(float(p[2]))}) m"


class FlightControlNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("flight_control", **kwargs)
        self.params = self.declare_params(FlightControlParams)
        self.bounds = self.params.bounds()
        self.dt = 1.0 / self.params.setpoint_rate_hz
        # what the FCU says, through the bridge
        self.status: Any = None
        self._status_ns: int | None = None
        self.position: FloatArray | None = None
        self._odometry: tuple[float, ...] | None = None  # position, q (wxyz), body velocity
        self._acks: dict[int, tuple[int, int]] = {}  # command -> (received ns, result)
        # what we command
        self.setpoint: Setpoint | None = None  # None: not streaming
        self.home: FloatArray | None = None  # m, the take-off point
        self._control_token = 0  # bumped by each motion goal: older ones are preempted
        self._arming = False
        self._sent_in_window = 0
        self.measured_rate_hz = 0.0

        self.create_subscription("quadmission_interfaces/msg/FcuStatus", "/fcu/status",
                                 self._on_status, qos_profile_default)
        self.create_subscription("nav_msgs/msg/Odometry", "/fcu/odometry", self._on_odometry,
                                 qos_profile_sensor_data)
        self.create_subscription("quadmission_interfaces/msg/FcuCommandAck", "/fcu/command_ack",
                                 self._on_ack, qos_profile_default)
        self.setpoint_pub = self.create_publisher("quadmission_interfaces/msg/FcuSetpoint",
                                                  "/fcu/setpoint", qos_profile_sensor_data)
        self.command_pub = self.create_publisher("quadmission_interfaces/msg/FcuCommand",
                                                 "/fcu/command", qos_profile_default)
        self.health_pub = self.create_publisher("quadmission_interfaces/msg/HealthReport",
                                                "~/health", qos_profile_default)
        self.stream_timer = self.create_timer(self.dt, self._stream)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)
        self.create_service(ARM, "~/arm", self._on_arm)
        self.create_service(DISARM, "~/disarm", self._on_disarm)
        self.takeoff_server = ActionServer(self, TAKEOFF, "~/takeoff", self._takeoff,
                                           goal_callback=self._check_takeoff)
        self.land_server = ActionServer(self, LAND, "~/land", self._land,
                                        goal_callback=self._check_land)
        self.reach_server = ActionServer(self, REACH, "~/reach", self._reach,
                                         goal_callback=self._check_reach)
        self.turn_server = ActionServer(self, TURN, "~/turn", self._turn,
                                        goal_callback=self._check_turn)

    # -- FCU state ------------------------------------------------------------------------
    def _on_status(self, msg: Any) -> None:
        was_armed = self.status is not None and self.status.armed
        self.status = msg
        self._status_ns = self.now().nanoseconds
        if was_armed and not msg.armed and not self._arming and self.setpoint is not None:
            self.get_logger().info("FCU disarmed: setpoint stream stopped")
            self.setpoint = None

    def _on_odometry(self, msg: Any) -> None:
        # 100 Hz: keep the numbers; yaw and map-frame velocity are worked out when asked
        p = msg.pose.pose.position
        o = msg.pose.pose.orientation
        v = msg.twist.twist.linear
        values = (p.x, p.y, p.z, o.w, o.x, o.y, o.z, v.x, v.y, v.z)
        if all(math.isfinite(x) for x in values[:7]):
            self._odometry = values
            self.position = np.array(values[:3], dtype=np.float64)

    @property
    def yaw(self) -> float:
        """Heading [rad] from /fcu/odometry (ENU), 0 before any."""
        if self._odometry is None:
            return 0.0
        _, _, _, w, x, y, z, _, _, _ = self._odometry
        return float(quat_to_yaw([w, x, y, z]))

    @property
    def velocity(self) -> FloatArray:
        """Velocity [m/s] in the map frame: /fcu/odometry's FLU body velocity, rotated."""
        if self._odometry is None:
            return np.zeros(3)
        _, _, _, w, x, y, z, vx, vy, vz = self._odometry
        return np.nan_to_num(quat_rotate([w, x, y, z], [vx, vy, vz]))

    def _on_ack(self, msg: Any) -> None:
        self._acks[int(msg.command)] = (self.now().nanoseconds, int(msg.result))

    def vehicle_state(self) -> VehicleState | None:
        """The latest /fcu/status, or None when it is older than ``status_timeout_s``."""
        s = self.status
        if s is None or self._status_ns is None:
            return None
        if self.now().nanoseconds - self._status_ns > self.params.status_timeout_s * 1e9:
            return None
        return VehicleState(connected=bool(s.connected), armed=bool(s.armed),
                            landed=bool(s.landed),
                            position_valid=bool(s.position_valid) and self.position is not None,
                            battery_warning=int(s.battery_warning), offboard=bool(s.offboard),
                            nav_state=int(s.nav_state))

    def _in_control(self) -> bool:
        s = self.vehicle_state()
        return s is not None and s.armed and s.offboard

    # -- the stream -----------------------------------------------------------------------
    def _stream(self) -> None:
        sp = self.setpoint
        if sp is None:
            return
        self._sent_in_window += 1
        self.setpoint_pub.publish(interfaces.new(
            "quadmission_interfaces/msg/FcuSetpoint",
            header=interfaces.new("std_msgs/msg/Header", stamp=self.now().to_msg(),
                                  frame_id=MAP_FRAME),
            position=_point(sp.position), velocity=_vector(sp.velocity),
            acceleration=_vector(np.full(3, math.nan)), yaw=float(sp.yaw), yaw_rate=math.nan))

    def hold(self, position: FloatArray | None = None, yaw: float | None = None) -> None:
        """Stream a setpoint that holds ``position`` (default: where the vehicle is)."""
        p = self.position if position is None else position
        assert p is not None
        if yaw is None:
            yaw = self.setpoint.yaw if self.setpoint is not None else self.yaw
        self.setpoint = Setpoint(np.array(p, dtype=np.float64), np.zeros(3), yaw)

    def _take_control(self) -> int:
        self._control_token += 1
        return self._control_token

    # -- FCU commands ---------------------------------------------------------------------
    async def command(self, command: Px4Command, param1: float = 0.0, param2: float = 0.0,
                      timeout_s: float = 0.0) -> CommandOutcome:
        """Send ``command`` and wait for its ack; send again after ``timeout_s`` (0: the
        parameter) without an ack or after a temporary rejection, up to
        ``command_attempts`` sends. A denial is final."""
        timeout = timeout_s if timeout_s > 0.0 else self.params.command_timeout_s
        result: int | None = None
        attempts = self.params.command_attempts
        for attempt in range(1, attempts + 1):
            sent_ns = self.now().nanoseconds
            self.command_pub.publish(interfaces.new(
                "quadmission_interfaces/msg/FcuCommand",
                header=interfaces.new("std_msgs/msg/Header", stamp=self.now().to_msg()),
                command=int(command), param1=param1, param2=param2))
            deadline = sent_ns + round(timeout * 1e9)
            ack: tuple[int, int] | None = None
            while self.now().nanoseconds < deadline:
                await self.sleep(min(self.dt, timeout))
                got = self._acks.get(int(command))
                if got is not None and got[0] >= sent_ns and got[1] != AckResult.IN_PROGRESS:
                    ack = got
                    break
            if ack is None:
                self.get_logger().warning(f"{command.name}: no ack (attempt {attempt}/{attempts})")
                continue
            result = ack[1]
            if result == AckResult.ACCEPTED:
                return CommandOutcome(int(command), True, result, attempt)
            if result != AckResult.TEMPORARILY_REJECTED:
                return CommandOutcome(int(command), False, result, attempt)
            self.get_logger().info(f"{command.name}: temporarily rejected "
                                   f"(attempt {attempt}/{attempts})")
            if attempt < attempts:
                await self.sleep(max(0.0, (deadline - self.now().nanoseconds) / 1e9))
        return CommandOutcome(int(command), False, result, attempts)

    async def _ensure_offboard(self) -> CommandOutcome:
        """Offboard mode, asked for when the FCU is not in it, then seen in /fcu/status."""
        if self._in_control():
            return CommandOutcome(Px4Command.DO_SET_MODE, True, AckResult.ACCEPTED, 0)
        out = await self.command(Px4Command.DO_SET_MODE, PX4_MODE_ENABLED,
                                 PX4_MAIN_MODE_OFFBOARD)
        if out.accepted:
            await self._wait_for(self._in_control)
        return out

    async def _wait_for(self, condition: Callable[[], bool]) -> bool:
        """Until ``condition()`` or ``2 * command_timeout_s`` (what /fcu/status takes to
        show an accepted command); whether it holds."""
        deadline = self.now().nanoseconds + round(self.params.command_timeout_s * 2e9)
        while not condition() and self.now().nanoseconds < deadline:
            await self.sleep(self.dt)
        return condition()

    # -- arm / disarm ---------------------------------------------------------------------
    def _on_arm(self, request: Any, response: Any) -> Any:
        problem = check_vehicle(self.vehicle_state(), need_disarmed=True,
                                battery_critical_warning=self.params.battery_critical_warning)
        if problem is None and self._arming:
            problem = GoalProblem(GoalError.ALREADY_ARMED, "arming already in progress")
        if problem is not None:
            response.result = (response.RESULT_BUSY if problem.error is GoalError.ALREADY_ARMED
                               else response.RESULT_DENIED)
            response.message = problem.message
            return response
        return self.create_task(self._arm(request, response))

    async def _arm(self, request: Any, response: Any) -> Any:
        self._arming = True
        try:
            self._take_control()
            assert self.position is not None
            self.home = self.position.copy()
            self.hold(self.home, self.yaw)
            await self.sleep(self.params.offboard_stream_s)
            mode = await self.command(Px4Command.DO_SET_MODE, PX4_MODE_ENABLED,
                                      PX4_MAIN_MODE_OFFBOARD, request.timeout)
            arm = mode
            if mode.accepted:
                arm = await self.command(Px4Command.COMPONENT_ARM_DISARM, 1.0,
                                         FORCE_MAGIC if request.force else 0.0, request.timeout)
            if arm.accepted:
                await self._wait_for(self._in_control)
        finally:
            self._arming = False
        return self._command_response(response, arm, "armed in offboard at "
                                      f"{_xyz(self.home)}", stop_stream_on_failure=True)

    def _command_response(self, response: Any, out: CommandOutcome, ok: str,
                          stop_stream_on_failure: bool) -> Any:
        response.success = out.accepted
        response.fcu_result = 0 if out.result is None else out.result
        if out.accepted:
            response.result = response.RESULT_OK
            response.message = ok
        else:
            response.result = (response.RESULT_TIMEOUT if out.timed_out
                               else response.RESULT_DENIED)
            response.message = out.describe()
            if stop_stream_on_failure:
                self.setpoint = None
        self.get_logger().info(response.message)
        return response

    def _on_disarm(self, request: Any, response: Any) -> Any:
        state = self.vehicle_state()
        problem = check_vehicle(state, need_armed=True, battery_critical_warning=None)
        if problem is not None and problem.error is GoalError.NO_POSITION:
            problem = None  # disarming needs no position
        if problem is not None:
            response.result = (response.RESULT_BUSY if problem.error is GoalError.NOT_ARMED
                               else response.RESULT_DENIED)
            response.message = "already disarmed" if problem.error is GoalError.NOT_ARMED \
                else problem.message
            return response
        return self.create_task(self._disarm(request, response))

    async def _disarm(self, request: Any, response: Any) -> Any:
        out = await self.command(Px4Command.COMPONENT_ARM_DISARM, 0.0,
                                 FORCE_MAGIC if request.force else 0.0, request.timeout)
        if out.accepted:
            self._take_control()
            self.setpoint = None
        return self._command_response(response, out, "disarmed", stop_stream_on_failure=False)

    # -- goal checks ----------------------------------------------------------------------
    def _verdict(self, *problems: GoalProblem | None) -> GoalResponse | Rejection:
        for problem in problems:
            if problem is not None:
                return Rejection(problem.message)
        return GoalResponse.ACCEPT

    def _check_flying(self) -> GoalProblem | None:
        return check_vehicle(self.vehicle_state(), need_armed=True, need_flying=True,
                             need_offboard=True,
                             battery_critical_warning=self.params.battery_critical_warning)

    def _check_takeoff(self, goal: Any) -> GoalResponse | Rejection:
        vehicle = check_vehicle(self.vehicle_state(), need_armed=True,
                                battery_critical_warning=self.params.battery_critical_warning)
        if vehicle is not None:
            return Rejection(vehicle.message)
        altitude = goal.altitude or self.params.takeoff_altitude
        home_z = self._home_z()
        return self._verdict(
            check_speed(goal.speed, self.params.max_speed),
            check_takeoff_altitude(altitude, home_z, self.bounds, self.params.min_altitude))

    def _home_z(self) -> float:
        state = self.vehicle_state()
        if (self.home is None or (state is not None and state.landed)) and \
                self.position is not None:
            return float(self.position[2])
        return float(self.home[2]) if self.home is not None else 0.0

    def _check_land(self, goal: Any) -> GoalResponse | Rejection:
        problem = check_vehicle(self.vehicle_state(), need_armed=True,
                                battery_critical_warning=None)
        if 0.0 < goal.speed < MIN_LAND_SPEED:
            return Rejection(f"land speed {goal.speed} m/s is below {MIN_LAND_SPEED} m/s: the "
                             "FCU's land detector would not see a descent")
        return self._verdict(problem, check_speed(goal.speed, self.params.max_speed))

    def _check_reach(self, goal: Any) -> GoalResponse | Rejection:
        p = goal.target.position
        return self._verdict(
            check_target([p.x, p.y, p.z], self.bounds, self.params.min_altitude),
            check_speed(goal.speed, self.params.max_speed),
            self._check_flying())

    def _check_turn(self, goal: Any) -> GoalResponse | Rejection:
        if not math.isfinite(goal.yaw):
            return Rejection(f"yaw {goal.yaw} is not finite")
        return self._verdict(check_speed(goal.yaw_rate, self.params.max_yaw_rate),
                             self._check_flying())

    # -- following a plan -----------------------------------------------------------------
    async def _follow(self, handle: ServerGoalHandle, plan: ReachPlan, radius: float,
                      feedback: Callable[[FloatArray, float], Any]) -> Ending:
        """Fly ``plan`` until inside ``radius`` of its target (stopped there when the plan
        stops at the target); publish ``feedback(position, distance_left)``."""
        token = self._take_control()
        timeout_ns = round((self.params.timeout_factor * plan.expected_duration()
                            + self.params.timeout_margin_s) * 1e9)
        start_ns = self.now().nanoseconds
        feedback_every = max(1, round(self.params.setpoint_rate_hz / self.params.feedback_rate_hz))
        progress = ReachProgress()
        settle_ns = round(self.params.settle_s * 1e9)
        settled_ns: int | None = None  # since when inside the radius and stopped
        tick = 0
        while True:
            ending = self._interrupted(handle, token)
            if ending is not None:
                return ending
            assert self.position is not None
            position = self.position
            progress = plan.advance(progress, position, self.dt)
            carrot = plan.carrot(progress)
            self.setpoint = Setpoint(carrot.position, carrot.velocity, carrot.yaw)
            distance = float(np.linalg.norm(position - plan.target))
            if tick % feedback_every == 0:
                handle.publish_feedback(feedback(position, distance))
            tick += 1
            arrived = progress.s >= plan.length and distance <= radius
            if not plan.stop_at_target:
                if arrived:  # passing through: no stop, no settling
                    self.hold(plan.target, plan.target_yaw)
                    return Ending.REACHED
            elif arrived and float(np.linalg.norm(self.velocity)) <= self.params.stop_speed:
                settled_ns = self.now().nanoseconds if settled_ns is None else settled_ns
                if self.now().nanoseconds - settled_ns >= settle_ns:
                    self.hold(plan.target, plan.target_yaw)
                    return Ending.REACHED
            else:
                settled_ns = None
            if self.now().nanoseconds - start_ns > timeout_ns:
                self.hold()
                return Ending.TIMEOUT
            await self.sleep(self.dt)

    def _interrupted(self, handle: ServerGoalHandle, token: int) -> Ending | None:
        if token != self._control_token:
            return Ending.PREEMPTED
        if handle.is_cancel_requested:
            self.hold()
            return Ending.CANCELED
        if not self._in_control():
            return Ending.LOST_CONTROL
        return None

    def _end(self, handle: ServerGoalHandle, result: Any, ending: Ending, message: str) -> Any:
        """Set the goal's state and the result's success/message for ``ending``."""
        result.success = ending is Ending.REACHED
        if ending is Ending.REACHED:
            handle.succeed()
        elif ending is Ending.CANCELED:
            handle.canceled()
        else:
            handle.abort()
        if ending is Ending.PREEMPTED:
            message = "preempted by a newer goal"
        elif ending is Ending.LOST_CONTROL:
            state = self.vehicle_state()
            nav = "unknown" if state is None else str(state.nav_state)
            message = f"lost offboard control (FCU nav_state {nav})"
        result.message = message
        self.get_logger().info(f"{ending.value}: {message}")
        return result

    def _plan(self, target: FloatArray, speed: float, stop_at_target: bool,
              target_yaw: float | None) -> ReachPlan:
        assert self.position is not None
        start_yaw = self.setpoint.yaw if self.setpoint is not None else self.yaw
        return ReachPlan.build(self.position, target, spacing=self.params.waypoint_spacing,
                               cruise_speed=speed, acceleration=self.params.acceleration,
                               waypoint_radius=self.params.waypoint_radius,
                               stop_at_target=stop_at_target, start_yaw=start_yaw,
                               target_yaw=target_yaw)

    # -- takeoff --------------------------------------------------------------------------
    async def _takeoff(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        result = interfaces.new(TAKEOFF.Result)
        assert self.position is not None
        state = self.vehicle_state()
        if self.home is None or (state is not None and state.landed):
            self.home = self.position.copy()
        home = self.home
        altitude = goal.altitude or self.params.takeoff_altitude
        target = np.array([home[0], home[1], home[2] + altitude])
        if self.setpoint is None:
            self.hold()
        mode = await self._ensure_offboard()
        if not mode.accepted or not self._in_control():
            handle.abort()
            result.result = result.RESULT_FCU_REJECTED
            result.message = mode.describe() if not mode.accepted else "offboard not entered"
            return result
        plan = self._plan(target, goal.speed or self.params.takeoff_speed, True, None)

        def feedback(position: FloatArray, distance: float) -> Any:
            return interfaces.new(TAKEOFF.Feedback, altitude=float(position[2] - home[2]),
                                  distance_left=abs(float(target[2] - position[2])))

        ending = await self._follow(handle, plan, self.params.reach_radius, feedback)
        codes = {Ending.REACHED: result.RESULT_OK, Ending.CANCELED: result.RESULT_CANCELED,
                 Ending.TIMEOUT: result.RESULT_TIMEOUT}
        result.result = codes.get(ending, result.RESULT_FCU_REJECTED)
        assert self.position is not None
        result.position = _point(self.position)
        return self._end(handle, result, ending,
                         f"at {fmt_m(float(self.position[2] - home[2]))} m above the take-off "
                         f"point {_xyz(home)}")

    # -- reach ----------------------------------------------------------------------------
    async def _reach(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        result = interfaces.new(REACH.Result)
        p, o = goal.target.position, goal.target.orientation
        target = np.array([p.x, p.y, p.z], dtype=np.float64)
        q = np.array([o.w, o.x, o.y, o.z])
        target_yaw = float(quat_to_yaw(q / np.linalg.norm(q))) if np.any(q) else None
        radius = goal.radius or self.params.reach_radius
        plan = self._plan(target, goal.speed or self.params.cruise_speed, goal.stop_at_target,
                          target_yaw)

        def feedback(position: FloatArray, distance: float) -> Any:
            return interfaces.new(REACH.Feedback, position=_point(position),
                                  distance_left=distance)

        ending = await self._follow(handle, plan, radius, feedback)
        assert self.position is not None
        error = float(np.linalg.norm(self.position - target))
        result.position = _point(self.position)
        result.distance_error = error
        codes = {Ending.REACHED: result.RESULT_OK, Ending.CANCELED: result.RESULT_CANCELED,
                 Ending.TIMEOUT: result.RESULT_TIMEOUT}
        result.result = codes.get(ending, result.RESULT_NOT_FLYING)
        verb = "reached" if ending is Ending.REACHED else "stopped"
        return self._end(handle, result, ending,
                         f"{verb} {fmt_m(error)} m from {_xyz(target)} (radius {fmt_m(radius)} m)")

    # -- turn -----------------------------------------------------------------------------
    async def _turn(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        result = interfaces.new(TURN.Result)
        token = self._take_control()
        start_yaw = self.setpoint.yaw if self.setpoint is not None else self.yaw
        target = wrap_pi(start_yaw + goal.yaw if goal.relative else goal.yaw)
        rate = goal.yaw_rate or self.params.yaw_rate
        if self.setpoint is None:
            self.hold()
        assert self.setpoint is not None
        hold_at = self.setpoint.position
        sp_yaw = start_yaw
        timeout_ns = round((self.params.timeout_factor * abs(wrap_pi(target - start_yaw)) / rate
                            + self.params.timeout_margin_s) * 1e9)
        start_ns = self.now().nanoseconds
        feedback_every = max(1, round(self.params.setpoint_rate_hz / self.params.feedback_rate_hz))
        tick = 0
        while True:
            ending = self._interrupted(handle, token)
            if ending is not None:
                break
            sp_yaw = yaw_toward(sp_yaw, target, rate, self.dt)
            self.setpoint = Setpoint(hold_at, np.zeros(3), sp_yaw)
            left = wrap_pi(target - self.yaw)
            if tick % feedback_every == 0:
                handle.publish_feedback(interfaces.new(TURN.Feedback, yaw=self.yaw,
                                                       angle_left=left))
            tick += 1
            if sp_yaw == target and abs(left) <= self.params.yaw_tolerance:
                ending = Ending.REACHED
                break
            if self.now().nanoseconds - start_ns > timeout_ns:
                ending = Ending.TIMEOUT
                break
            await self.sleep(self.dt)
        if ending is Ending.CANCELED:
            self.hold(hold_at, self.yaw)
        result.yaw = self.yaw
        codes = {Ending.REACHED: result.RESULT_OK, Ending.CANCELED: result.RESULT_CANCELED,
                 Ending.TIMEOUT: result.RESULT_TIMEOUT}
        result.result = codes.get(ending, result.RESULT_NOT_FLYING)
        return self._end(handle, result, ending,
                         f"heading {self.yaw:.3f} rad, target {target:.3f} rad")

    # -- land -----------------------------------------------------------------------------
    async def _land(self, handle: ServerGoalHandle) -> Any:
        """Land where the vehicle is, then touchdown (and disarm).

        ``speed`` 0: the FCU's own landing (NAV_LAND, PX4's MPC_LAND_SPEED); the hold
        setpoint keeps streaming at the vehicle's position, so a cancel can take offboard
        back at once. ``speed`` > 0: we descend in offboard at that speed, holding x and y,
        until the FCU detects the touchdown."""
        goal = handle.request
        result = interfaces.new(LAND.Result)
        token = self._take_control()
        if self.setpoint is None:
            self.hold()
        descend_at = None
        if goal.speed > 0.0:
            assert self.position is not None
            descend_at = self.position.copy()
        else:
            out = await self.command(Px4Command.NAV_LAND)
            if not out.accepted:
                handle.abort()
                result.result = result.RESULT_FCU_REJECTED
                result.message = out.describe()
                return result
        home_z = self.home[2] if self.home is not None else 0.0
        start_ns = self.now().nanoseconds
        feedback_every = max(1, round(self.params.setpoint_rate_hz / self.params.feedback_rate_hz))
        tick = 0
        disarm_sent = False
        ending: Ending | None = None
        while ending is None:
            state = self.vehicle_state()
            assert self.position is not None
            if token != self._control_token:
                ending = Ending.PREEMPTED
                break
            if handle.is_cancel_requested:
                self.hold()
                mode = await self._ensure_offboard()
                ending = Ending.CANCELED if mode.accepted else Ending.LOST_CONTROL
                break
            touched_down = state is not None and state.landed
            if descend_at is not None and not touched_down:
                x, y = descend_at[:2]
                yaw = self.setpoint.yaw if self.setpoint is not None else self.yaw
                self.setpoint = Setpoint(np.array([x, y, math.nan]),
                                         np.array([0.0, 0.0, -goal.speed]), yaw)
            elif self.setpoint is not None:
                self.hold()  # the stream follows the vehicle down
            if tick % feedback_every == 0:
                handle.publish_feedback(interfaces.new(
                    LAND.Feedback, altitude=float(self.position[2] - home_z),
                    vertical_speed=float(self.velocity[2])))
            tick += 1
            if state is not None and state.landed:
                if not state.armed:
                    ending = Ending.REACHED
                    break
                if not goal.disarm:
                    ending = Ending.REACHED
                    break
                if not disarm_sent:
                    disarm_sent = True
                    await self.command(Px4Command.COMPONENT_ARM_DISARM, 0.0)
                    continue
            if self.now().nanoseconds - start_ns > self.params.land_timeout_s * 1e9:
                ending = Ending.TIMEOUT
                break
            await self.sleep(self.dt)
        assert self.position is not None
        result.position = _point(self.position)
        codes = {Ending.REACHED: result.RESULT_OK, Ending.CANCELED: result.RESULT_CANCELED,
                 Ending.TIMEOUT: result.RESULT_TIMEOUT}
        result.result = codes.get(ending, result.RESULT_FCU_REJECTED)
        if ending is Ending.REACHED and goal.disarm:
            self.setpoint = None
        return self._end(handle, result, ending, f"landed at {_xyz(self.position)}"
                         if ending is Ending.REACHED else f"stopped at {_xyz(self.position)}")

    # -- health ---------------------------------------------------------------------------
    def _publish_health(self) -> None:
        now = self.now()
        self.measured_rate_hz = self._sent_in_window * self.params.health_rate_hz
        self._sent_in_window = 0
        state = self.vehicle_state()
        problems: list[str] = []
        warnings: list[str] = []
        if state is None:
            level = HealthLevel.STALE
            problems.append("no /fcu/status")
        else:
            if not state.connected:
                problems.append("FCU not connected")
            if not state.position_valid:
                problems.append("no valid position estimate")
            if state.battery_warning >= self.params.battery_critical_warning:
                problems.append(f"battery critical (warning level {state.battery_warning})")
            elif state.battery_warning > 0:
                warnings.append(f"battery low (warning level {state.battery_warning})")
            if self.status.failsafe:
                warnings.append("FCU failsafe active")
            level = (HealthLevel.ERROR if problems else
                     HealthLevel.WARN if warnings else HealthLevel.OK)
        s = self.status
        values = {
            "connected": state is not None and state.connected,
            "armed": state is not None and state.armed,
            "offboard": state is not None and state.offboard,
            "position_valid": state is not None and state.position_valid,
            "nav_state": -1 if s is None else int(s.nav_state),
            "battery_remaining": math.nan if s is None else float(s.battery_remaining),
            "battery_warning": -1 if s is None else int(s.battery_warning),
            "streaming": self.setpoint is not None,
            "setpoint_rate_hz": self.measured_rate_hz,
        }
        health = interfaces.new(
            "quadmission_interfaces/msg/ModuleHealth", name="flight_control", level=int(level),
            message="; ".join(problems + warnings),
            last_update=now.to_msg(),
            values=[interfaces.new("diagnostic_msgs/msg/KeyValue", key=k,
                                   value=str(v).lower() if isinstance(v, bool) else str(v))
                    for k, v in values.items()])
        self.health_pub.publish(interfaces.new(
            "quadmission_interfaces/msg/HealthReport",
            header=interfaces.new("std_msgs/msg/Header", stamp=now.to_msg()),
            level=int(level), modules=[health]))


__all__ = ["AckResult", "CommandOutcome", "FlightControlNode", "FlightControlParams",
           "Px4Command", "Setpoint"]
