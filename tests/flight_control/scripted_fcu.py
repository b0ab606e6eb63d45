"""A flight controller reduced to a script, on the bridge's ``/fcu/*`` topics: it follows
the setpoints at a set speed, answers commands as the test says (accept by default, a
given result, or no ack at all) and reports its state. It lets the flight-control node be
tested without MuJoCo; the real firmware flies it in test_flight_control_node.py."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import interfaces
from interfaces.px4 import CommandResult, NavigationState, VehicleCmd
from runtime import Node, qos_profile_default, qos_profile_sensor_data

ODOMETRY_PERIOD_S = 0.02
STATUS_PERIOD_S = 0.1
LAND_SPEED = 0.7  # m/s, NAV_LAND descent
GROUND_Z = 0.05  # m, below this the land detector says landed


class ScriptedFcu(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("scripted_fcu", **kwargs)
        self.position = np.array([1.0, 1.0, 0.0])
        self.speed = 1.0  # m/s toward the setpoint; 0: the vehicle does not move
        self.armed = False
        self.offboard = False
        self.landing = False
        self.nav_state = NavigationState.AUTO_LOITER
        self.battery_warning = 0
        self.obeys_mode_changes = True  # False: acks DO_SET_MODE, stays where it is
        self.answers: dict[int, list[int | None]] = {}  # per send; None: no ack
        self.commands: list[tuple[float, int, float, float]] = []  # t, command, p1, p2
        self.setpoint: Any = None
        self.create_subscription("quadmission_interfaces/msg/FcuCommand", "/fcu/command",
                                 self._on_command, qos_profile_default)
        self.create_subscription("quadmission_interfaces/msg/FcuSetpoint", "/fcu/setpoint",
                                 self._on_setpoint, qos_profile_sensor_data)
        self.ack_pub = self.create_publisher("quadmission_interfaces/msg/FcuCommandAck",
                                             "/fcu/command_ack", qos_profile_default)
        self.status_pub = self.create_publisher("quadmission_interfaces/msg/FcuStatus",
                                                "/fcu/status", qos_profile_default)
        self.odometry_pub = self.create_publisher("nav_msgs/msg/Odometry", "/fcu/odometry",
                                                  qos_profile_sensor_data)
        self.create_timer(ODOMETRY_PERIOD_S, self._move)
        self.create_timer(STATUS_PERIOD_S, self._status)

    def fly_at(self, position: tuple[float, float, float]) -> None:
        """Armed, in offboard, airborne at ``position``."""
        self.position = np.array(position, dtype=np.float64)
        self.armed, self.offboard, self.nav_state = True, True, NavigationState.OFFBOARD

    def sent(self, command: VehicleCmd) -> list[float]:
        """When ``command`` was received [s]."""
        return [t for t, c, _, _ in self.commands if c == command]

    @property
    def landed(self) -> bool:
        return bool(self.position[2] < GROUND_Z)

    def _on_setpoint(self, msg: Any) -> None:
        self.setpoint = msg

    def _on_command(self, msg: Any) -> None:
        t = self.now().nanoseconds / 1e9
        self.commands.append((t, int(msg.command), float(msg.param1), float(msg.param2)))
        script = self.answers.get(int(msg.command), [])
        result = script.pop(0) if script else CommandResult.ACCEPTED
        if result is None:
            return  # the ack is lost
        if result == CommandResult.ACCEPTED:
            if msg.command == VehicleCmd.DO_SET_MODE and self.obeys_mode_changes:
                self.offboard, self.landing = True, False
                self.nav_state = NavigationState.OFFBOARD
            elif msg.command == VehicleCmd.COMPONENT_ARM_DISARM:
                self.armed = msg.param1 == 1.0
            elif msg.command == VehicleCmd.NAV_LAND:
                self.offboard, self.landing = False, True
                self.nav_state = NavigationState.AUTO_LAND
        self.ack_pub.publish(interfaces.new("quadmission_interfaces/msg/FcuCommandAck",
                                            command=msg.command, result=int(result)))

    def _move(self) -> None:
        dt = ODOMETRY_PERIOD_S
        velocity = np.zeros(3)
        if self.landing and not self.landed:
            velocity = np.array([0.0, 0.0, -LAND_SPEED])
        elif self.armed and self.offboard and self.setpoint is not None and self.speed > 0:
            sp = self.setpoint
            target = np.array([sp.position.x, sp.position.y, sp.position.z])
            free = np.isnan(target)
            target[free] = self.position[free] + np.array(
                [sp.velocity.x, sp.velocity.y, sp.velocity.z])[free] * dt
            delta = target - self.position
            distance = float(np.linalg.norm(delta))
            step = min(distance, self.speed * dt)
            velocity = delta / distance * step / dt if distance > 0 else np.zeros(3)
        self.position = self.position + velocity * dt
        self.position[2] = max(0.0, self.position[2])
        odometry = interfaces.new("nav_msgs/msg/Odometry")
        p = odometry.pose.pose
        p.position.x, p.position.y, p.position.z = (float(v) for v in self.position)
        p.orientation.w = 1.0
        v = odometry.twist.twist.linear
        v.x, v.y, v.z = (float(x) for x in velocity)
        odometry.header.stamp = self.now().to_msg()
        self.odometry_pub.publish(odometry)

    def _status(self) -> None:
        self.status_pub.publish(interfaces.new(
            "quadmission_interfaces/msg/FcuStatus", connected=True, armed=self.armed,
            nav_state=int(self.nav_state), offboard=self.offboard, landed=self.landed,
            position_valid=True, pre_flight_checks_pass=True,
            battery_warning=self.battery_warning, battery_remaining=math.nan))
