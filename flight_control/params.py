"""The flight-control node's parameters: types, units and ranges here, values in
``config/flight_control.yaml``; the field bounds come from the app (the arena in use)."""

from __future__ import annotations

from dataclasses import dataclass

from flight_control.behaviours.reach import ReachTuning
from flight_control.goal_checks import FieldBounds
from runtime import ParameterError, param


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
    min_land_speed: float = param(unit="m/s", range=(0.05, 1.0),
                                  description="slowest offboard descent the FCU's land "
                                              "detector reads as a landing")
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
    wall_clearance: float = param(unit="m", range=(0.0, 5.0),
                                  description="reach targets stay this far from the walls "
                                              "and the ceiling")
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
        for name, limit in (("cruise_speed", "max_speed"), ("takeoff_speed", "max_speed"),
                            ("min_land_speed", "max_speed"), ("yaw_rate", "max_yaw_rate")):
            if getattr(self, name) > getattr(self, limit):
                raise ParameterError(f"flight_control.{name}: {getattr(self, name)} is above "
                                     f"{limit} {getattr(self, limit)}")

    @property
    def period_s(self) -> float:
        """Setpoint period [s]: behaviours step and the stream sends at this rate."""
        return 1.0 / self.setpoint_rate_hz

    @property
    def mode_wait_s(self) -> float:
        """How long /fcu/status may take to show an accepted mode change [s]."""
        return 2.0 * self.command_timeout_s

    def reach_tuning(self) -> ReachTuning:
        return ReachTuning(spacing=self.waypoint_spacing, acceleration=self.acceleration,
                           waypoint_radius=self.waypoint_radius, stop_speed=self.stop_speed,
                           settle_s=self.settle_s)


#: Where the field bounds come from; they are never in config/flight_control.yaml.
FIELD_SOURCE = ("the field comes from the arena in use: the app must give field_min and "
                "field_max as parameter overrides "
                "(quadmission.assembly.companion.field_bounds(arena))")


@dataclass(frozen=True)
class FieldParams:
    """The allowed flight volume, from the arena in use (the app passes it)."""

    field_min: tuple[float, ...] = param(unit="m", range=(-1000.0, 1000.0),
                                         description="allowed volume, lower corner x, y, z")
    field_max: tuple[float, ...] = param(unit="m", range=(-1000.0, 1000.0),
                                         description="allowed volume, upper corner x, y, z")

    def bounds(self, clearance: float = 0.0) -> FieldBounds:
        """The field, ``clearance`` [m] in from the walls and the ceiling."""
        try:
            return FieldBounds.of(self.field_min, self.field_max).shrunk(clearance)
        except ValueError as exc:
            raise ParameterError(f"flight_control.field_min/field_max with wall_clearance "
                                 f"{clearance} m: {exc}") from None



@dataclass(frozen=True)
class BridgeParams:
    """The FCU bridge's parameters (``config/fcu_bridge.yaml``)."""

    timesync_rate_hz: float = param(unit="Hz", range=(0.5, 500.0),
                                    description="Timesync exchanges per second")
    timesync_estimator: str = param(choices=("px4", "kalman"),
                                    description="seed 000 / PX4 filter, or ours")
    timesync_source: str = param(
        choices=("exchange", "fcu_status"),
        description="our Timesync exchange (filtered by timesync_estimator), or the "
                    "offset the FCU reports on /fmu/out/timesync_status (PX4 v1.17)")
    pose_history_s: float = param(unit="s", range=(0.1, 60.0),
                                  description="odometry kept for /fcu/pose_at")
    connection_timeout_s: float = param(unit="s", range=(0.05, 10.0),
                                        description="FCU silent this long: disconnected")
    status_rate_hz: float = param(unit="Hz", range=(0.5, 100.0),
                                  description="/fcu/status republish rate")


__all__ = ["FIELD_SOURCE", "BridgeParams", "FieldParams", "FlightControlParams"]
