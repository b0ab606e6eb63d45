"""The flight-control node: the layer that hides PX4 from everything above it (seed 003,
sec. 3.2.2). It only wires; the logic is in pure modules:

- actions ``takeoff``, ``land``, ``reach``, ``turn`` (:mod:`flight_control.flight_actions`):
  pure behaviours (:mod:`flight_control.behaviours`) stepped by one action base
  (:mod:`flight_control.behaviour_server`: goal checks, preemption, cancel, timeout,
  feedback, results);
- services ``arm`` and ``disarm``: arming streams the hold setpoint for
  ``offboard_stream_s`` (PX4 wants the heartbeat for more than 1 s), asks for offboard
  mode, then arms; every FCU command goes through the retry protocol
  (:mod:`flight_control.command_protocol`); an arm while arming is refused (BUSY);
- ``~/health`` (HealthReport, ``health_rate_hz``) for preflight checks.

While it has control (from arming until the vehicle is disarmed) a timer streams the
current setpoint on ``/fcu/setpoint`` at ``setpoint_rate_hz``: the bridge turns each one
into an OffboardControlMode heartbeat plus a TrajectorySetpoint, so the stream is the
offboard heartbeat, and stopping it makes the FCU fail safe.

It reads the FCU only through the bridge: ``/fcu/status``, ``/fcu/odometry`` (ENU map
frame, FLU body velocity) and ``/fcu/command_ack``. Parameters:
``config/flight_control.yaml``, and ``field_min``/``field_max`` from the app (the arena).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

import interfaces
from flight_control.behaviour_server import BehaviourServer, FcuCommands
from flight_control.behaviours import OFFBOARD, CommandReply, Observation, Setpoint, arm_disarm
from flight_control.command_protocol import CommandProtocol
from flight_control.flight_actions import LAND, REACH, TAKEOFF, TURN, motion_actions, xyz
from flight_control.frames import quat_rotate_f, quat_to_yaw_f
from flight_control.goal_checks import (
    NO_POSITION_MESSAGE,
    GoalError,
    VehicleState,
    battery_critical,
    check_vehicle,
)
from flight_control.health import health_report
from flight_control.params import FIELD_SOURCE, FieldParams, FlightControlParams
from interfaces import graph
from runtime import Node, ParameterError

NODE_NAME = "flight_control"
ARM = graph.ARM.interface()
DISARM = graph.DISARM.interface()
HEALTH: Any = interfaces.get_message("quadmission_interfaces/msg/ModuleHealth")
MAP_FRAME = "map"


class FlightControlNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(FlightControlParams)
        try:
            self.bounds = self.declare_params(FieldParams).bounds(
                self.params.wall_clearance)
        except ParameterError as exc:
            raise ParameterError(f"{exc}; {FIELD_SOURCE}") from None
        # what the FCU says, through the bridge
        self.status: Any = None
        self._status_ns: int | None = None
        self.position: np.ndarray | None = None  # m, map frame
        self._odometry: tuple[float, ...] | None = None  # position, q (wxyz), body velocity
        # what we command
        self.setpoint: Setpoint | None = None  # None: not streaming
        self.home: np.ndarray | None = None  # m, the take-off point
        self._arming = False
        self._sent_in_window = 0
        self.measured_rate_hz = 0.0

        for topic, callback in ((graph.FCU_STATUS, self._on_status),
                                (graph.FCU_ODOMETRY, self._on_odometry)):
            self.create_subscription(topic.type, topic.name, callback, topic.subscriber_qos)
        self.setpoint_pub = self.create_publisher(
            graph.FCU_SETPOINT.type, graph.FCU_SETPOINT.name, graph.FCU_SETPOINT.qos)
        health = graph.HEALTH[NODE_NAME]
        self.health_pub = self.create_publisher(health.type, health.name, health.qos)
        self.stream_timer = self.create_timer(self.params.period_s, self._stream)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)
        self.create_service(ARM, graph.ARM.name, self._on_arm)
        self.create_service(DISARM, graph.DISARM.name, self._on_disarm)
        self.commands = FcuCommands(self, self.params)
        self.behaviours = BehaviourServer(self, self, self.commands, self.params)
        for action in motion_actions(self):
            self.behaviours.serve(action)

    # -- FCU state ------------------------------------------------------------------------
    def _on_status(self, msg: Any) -> None:
        was_armed = self.status is not None and self.status.armed
        self.status = msg
        self._status_ns = self.now().nanoseconds
        if was_armed and not msg.armed and not self._arming and self.setpoint is not None:
            self.get_logger().info("FCU disarmed: setpoint stream stopped")
            self.setpoint = None
        elif (self.setpoint is None and msg.armed and not msg.landed and not self._arming
              and self.position is not None and (msg.offboard or msg.offboard_signal_lost)):
            # flying in offboard with nobody streaming: this node was restarted (its process
            # respawned). Hold where the vehicle is, so the FCU has its signal back within
            # its failsafe hold and returns to OFFBOARD instead of landing
            self.setpoint = Setpoint.hold(self.position, self.yaw)
            self.get_logger().info(f"FCU flying in offboard, no stream: holding at "
                                   f"{xyz(self.position)}")

    def _on_odometry(self, msg: Any) -> None:
        # 100 Hz: keep the numbers; yaw and map-frame velocity are worked out when asked
        p, o, v = msg.pose.pose.position, msg.pose.pose.orientation, msg.twist.twist.linear
        values = (p.x, p.y, p.z, o.w, o.x, o.y, o.z, v.x, v.y, v.z)
        if all(math.isfinite(x) for x in values[:7]):
            self._odometry = values
            self.position = np.array(values[:3], dtype=np.float64)

    @property
    def yaw(self) -> float:
        """Heading [rad] from /fcu/odometry (ENU), 0 before any."""
        return 0.0 if self._odometry is None else quat_to_yaw_f(self._odometry[3:7])

    @property
    def velocity(self) -> np.ndarray:
        """Velocity [m/s] in the map frame: /fcu/odometry's FLU body velocity, rotated
        (``np.nan_to_num``: a NaN component, not known, is 0)."""
        if self._odometry is None:
            return np.zeros(3)
        v = quat_rotate_f(self._odometry[3:7], self._odometry[7:])
        return np.array(v) if all(map(math.isfinite, v)) else np.nan_to_num(np.array(v))

    def vehicle_state(self) -> VehicleState | None:
        """The latest /fcu/status, or None when it is older than ``status_timeout_s``."""
        s = self.status
        if s is None or self._status_ns is None or \
                self.now().nanoseconds - self._status_ns > self.params.status_timeout_s * 1e9:
            return None
        return VehicleState(connected=bool(s.connected), armed=bool(s.armed),
                            landed=bool(s.landed),
                            position_valid=bool(s.position_valid) and self.position is not None,
                            battery_warning=int(s.battery_warning), offboard=bool(s.offboard),
                            nav_state=int(s.nav_state))

    def observe(self, reply: CommandReply | None = None) -> Observation | None:
        """What a behaviour sees now; None before the first position."""
        if self.position is None:
            return None
        return Observation(self.position.copy(), self.velocity, self.yaw, self.vehicle_state(),
                           reply)

    def _in_control(self) -> bool:
        obs = self.observe()
        return obs is not None and obs.in_control

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
            position=interfaces.point(*sp.position),
            velocity=interfaces.new("geometry_msgs/msg/Vector3", x=float(sp.velocity[0]),
                                    y=float(sp.velocity[1]), z=float(sp.velocity[2])),
            acceleration=interfaces.new("geometry_msgs/msg/Vector3", x=math.nan, y=math.nan,
                                        z=math.nan),
            yaw=float(sp.yaw), yaw_rate=math.nan))

    # -- arm / disarm ---------------------------------------------------------------------
    def _on_arm(self, request: Any, response: Any) -> Any:
        problem = check_vehicle(self.vehicle_state(), need_disarmed=True,
                                battery_critical_warning=self.params.battery_critical_warning)
        if problem is None and self._arming:
            response.result = response.RESULT_BUSY
            response.message = "arming already in progress"
            return response
        if problem is not None:
            response.result = (response.RESULT_BUSY if problem.error is GoalError.ALREADY_ARMED
                               else response.RESULT_DENIED)
            response.message = problem.message
            return response
        return self.create_task(self._arm(request, response))

    async def _arm(self, request: Any, response: Any) -> Any:
        self._arming = True
        try:
            self.behaviours.take_control()
            assert self.position is not None
            self.home = self.position.copy()
            self.setpoint = Setpoint.hold(self.home, self.yaw)
            await self.sleep(self.params.offboard_stream_s)
            out = await self.commands.run(OFFBOARD, request.timeout)
            if out.accepted:
                out = await self.commands.run(arm_disarm(True, force=request.force),
                                              request.timeout)
            in_control = out.accepted and await self._wait_for(self._in_control)
        finally:
            self._arming = False
        if not in_control:
            self.setpoint = None
        if out.accepted and not in_control:  # acked, but /fcu/status never showed it
            state = self.vehicle_state()
            response.success, response.fcu_result = False, int(out.result or 0)
            response.result = response.RESULT_TIMEOUT
            response.message = (f"the FCU accepted arming but was not armed in offboard after "
                                f"{self.params.mode_wait_s:.1f} s (nav_state "
                                f"{'unknown' if state is None else state.nav_state})")
            self.get_logger().warning(response.message)
            return response
        return self._command_response(response, out, f"armed in offboard at {xyz(self.home)}")

    def _on_disarm(self, request: Any, response: Any) -> Any:
        problem = check_vehicle(self.vehicle_state(), need_armed=True,
                                battery_critical_warning=None)
        if problem is not None and problem.error is not GoalError.NO_POSITION:
            not_armed = problem.error is GoalError.NOT_ARMED  # disarming needs no position
            response.result = response.RESULT_BUSY if not_armed else response.RESULT_DENIED
            response.message = "already disarmed" if not_armed else problem.message
            return response
        return self.create_task(self._disarm(request, response))

    async def _disarm(self, request: Any, response: Any) -> Any:
        out = await self.commands.run(arm_disarm(False, force=request.force), request.timeout)
        if out.accepted:
            self.behaviours.take_control()
            self.setpoint = None
        return self._command_response(response, out, "disarmed")

    def _command_response(self, response: Any, out: CommandProtocol, ok: str) -> Any:
        response.success = out.accepted
        response.fcu_result = 0 if out.result is None else out.result
        response.result = (response.RESULT_OK if out.accepted else response.RESULT_TIMEOUT
                           if out.timed_out else response.RESULT_DENIED)
        response.message = ok if out.accepted else out.describe()
        self.get_logger().info(response.message)
        return response

    async def _wait_for(self, condition: Callable[[], bool]) -> bool:
        """Until ``condition()`` or ``mode_wait_s`` (what /fcu/status takes to show an
        accepted command); whether it holds."""
        deadline = self.now().nanoseconds + round(self.params.mode_wait_s * 1e9)
        while not condition() and self.now().nanoseconds < deadline:
            await self.sleep(self.params.period_s)
        return condition()

    # -- health ---------------------------------------------------------------------------
    def _publish_health(self) -> None:
        now = self.now()
        self.measured_rate_hz = self._sent_in_window * self.params.health_rate_hz
        self._sent_in_window = 0
        state, s = self.vehicle_state(), self.status
        problems: list[str] = []
        warnings: list[str] = []
        if state is None:
            problems.append("no /fcu/status")
        else:
            if not state.connected:
                problems.append("FCU not connected")
            if not state.position_valid:
                problems.append(NO_POSITION_MESSAGE)
            # the battery is the vehicle's state, not a fault of this module: a warning here
            # (goals that need a good battery are refused); the mission reacts to it on its
            # own cause from /fcu/status (BATTERY_LOW / BATTERY_CRITICAL), so an error here
            # would add a MODULE_ERROR whose HOLD stops the landing the battery asked for
            if battery_critical(state.battery_warning, self.params.battery_critical_warning):
                warnings.append(f"battery critical (warning level {state.battery_warning})")
            elif state.battery_warning > 0:
                warnings.append(f"battery low (warning level {state.battery_warning})")
            if s.failsafe:
                warnings.append("FCU failsafe active")
        level = (HEALTH.LEVEL_STALE if state is None else HEALTH.LEVEL_ERROR if problems
                 else HEALTH.LEVEL_WARN if warnings else HEALTH.LEVEL_OK)
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
        self.health_pub.publish(health_report("flight_control", level,
                                              "; ".join(problems + warnings), values,
                                              now.to_msg()))


__all__ = ["ARM", "DISARM", "LAND", "REACH", "TAKEOFF", "TURN", "FlightControlNode"]
