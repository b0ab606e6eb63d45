"""Parameters of the mission node and the simulated operator: types, units and ranges here,
values in ``config/mission.yaml`` and ``config/operator.yaml``.

What the contest tells every team before the run (where the pads are, which pad the
drone starts from; for the operator, what each robot carries) is not in those files: it
comes from the arena in use, and the app passes it as parameter overrides
(``quadmission.assembly.companion``), as it passes the field bounds to flight control.
"""

from __future__ import annotations

from dataclasses import dataclass

from runtime import ParameterError, param
from runtime.parameters import validate_parameters

FIELD_SOURCE = ("the pads come from the arena in use: the app must give pad_ids, pad_x, "
                "pad_y and start_pad as parameter overrides")


@dataclass(frozen=True)
class PadsParams:
    """The landing pads as the rules publish them: ids and map-frame centres [m]."""

    pad_ids: tuple[int, ...] = param(range=(1, 1000), description="pad marker ids")
    pad_x: tuple[float, ...] = param(unit="m", range=(-1000.0, 1000.0),
                                     description="pad centres, x (map frame)")
    pad_y: tuple[float, ...] = param(unit="m", range=(-1000.0, 1000.0),
                                     description="pad centres, y (map frame)")
    start_pad: int = param(range=(1, 1000), description="the pad the drone takes off from")

    def __post_init__(self) -> None:
        validate_parameters(self)
        if not len(self.pad_ids) == len(self.pad_x) == len(self.pad_y):
            raise ParameterError(f"pad_ids, pad_x, pad_y: {len(self.pad_ids)}, "
                                 f"{len(self.pad_x)} and {len(self.pad_y)} values; one per pad")
        if len(set(self.pad_ids)) != len(self.pad_ids):
            raise ParameterError(f"pad_ids: a pad appears twice in {list(self.pad_ids)}")
        if self.start_pad not in self.pad_ids:
            raise ParameterError(f"start_pad: {self.start_pad} is not among pad_ids "
                                 f"{list(self.pad_ids)}")

    def positions(self) -> dict[int, tuple[float, float]]:
        return {i: (x, y) for i, x, y in zip(self.pad_ids, self.pad_x, self.pad_y, strict=True)}


@dataclass(frozen=True)
class MissionParams:
    """Parameters of ``mission``; values live in ``config/mission.yaml``."""

    target_robot: int = param(range=(0, 1000), description="the robot marker to find")
    cruise_altitude: float = param(unit="m", range=(0.5, 10.0),
                                   description="flight height for take-off and transit")
    explore_altitude: float = param(unit="m", range=(0.5, 10.0),
                                    description="flight height of the robot search: the "
                                                "down camera reads a wider strip")
    explore_budget_s: float = param(unit="s", range=(0.0, 36000.0),
                                    description="explore at most this long, then stop with "
                                                "robot_not_found; 0 = no limit")
    search_radius_near: float = param(unit="m", range=(0.0, 5.0),
                                      description="first landing attempt looks this far")
    search_radius_wide: float = param(unit="m", range=(0.0, 10.0),
                                      description="the pad-search branch looks this far")
    action_servers: tuple[str, ...] = param(description="actions that must be ready before "
                                                        "the start")
    preflight_timeout_s: float = param(unit="s", range=(0.1, 600.0),
                                       description="every module must answer within this")
    silence_timeout_s: float = param(unit="s", range=(0.1, 600.0),
                                     description="no health report this long = module silent")
    sequence_timeout_s: float = param(unit="s", range=(1.0, 3600.0),
                                      description="wait this long for the operator's sequence")
    report_hover_s: float = param(unit="s", range=(0.0, 60.0),
                                  description="hover over the robot collecting its pictures")
    picture_timeout_s: float = param(unit="s", range=(0.0, 600.0),
                                     description="then wait this long more for a picture")
    max_pictures: int = param(range=(1, 20), description="robot pictures sent")
    battery_low_warning: int = param(range=(1, 3),
                                     description="px4 WARNING_* that means return and land")
    battery_critical_warning: int = param(range=(1, 3),
                                          description="px4 WARNING_* that means land now")
    land_speed: float = param(unit="m/s", range=(0.0, 3.0),
                              description="land-now descent (0: the layer's default)")
    arm_attempts: int = param(range=(1, 20), description="arm calls before giving up")
    failure_cause_wait_s: float = param(
        unit="s", range=(0.0, 10.0),
        description="an action that fails in the air waits this long for a cause it may "
                    "be the consequence of (the position estimate or the FCU link lost); "
                    "none: offboard_lost under the FCU's failsafe, else a flight error (on "
                    "the ground: at once)")
    status_timeout_s: float = param(unit="s", range=(0.2, 60.0),
                                    description="in the air, no /fcu/status this long = the "
                                                "FCU link lost (offboard_lost)")
    recovery_settle_s: float = param(unit="s", range=(0.0, 60.0),
                                     description="a transient cause clear this long: resume")
    recovery_deadline_s: float = param(unit="s", range=(0.1, 3600.0),
                                       description="a transient cause not clear after this "
                                                   "long held: the permanent reaction")
    max_resumes: int = param(range=(0, 100),
                             description="resumes after transient errors per mission; 0: "
                                         "every error takes its permanent reaction at once")
    state_rate_hz: float = param(unit="Hz", range=(0.1, 100.0),
                                 description="/mission/state publish rate (and on change)")
    watchdog_rate_hz: float = param(unit="Hz", range=(1.0, 100.0),
                                    description="how often alerts and timeouts are checked")

    def __post_init__(self) -> None:
        validate_parameters(self)
        if self.search_radius_near > self.search_radius_wide:
            raise ParameterError(f"mission.search_radius_near {self.search_radius_near} m is "
                                 f"above search_radius_wide {self.search_radius_wide} m")
        if self.battery_low_warning > self.battery_critical_warning:
            raise ParameterError("mission.battery_low_warning is above "
                                 "battery_critical_warning")
        if self.recovery_settle_s >= self.recovery_deadline_s:
            raise ParameterError(f"mission.recovery_settle_s {self.recovery_settle_s} s is not "
                                 f"below recovery_deadline_s {self.recovery_deadline_s} s: "
                                 "nothing could ever resume")


@dataclass(frozen=True)
class RobotsParams:
    """What each robot carries (the arena's, passed by the app): ``robot_points`` holds one
    row of points per robot, one value per pad in ``pad_ids`` order."""

    robot_ids: tuple[int, ...] = param(range=(1, 1000), description="robot marker ids")
    robot_points: tuple[int, ...] = param(range=(0, 100000),
                                          description="points, robot-major, pad_ids order")


@dataclass(frozen=True)
class OperatorParams:
    """Parameters of ``operator``; values live in ``config/operator.yaml``."""

    start_after_s: float = param(unit="s", range=(0.0, 3600.0),
                                 description="send START this long after the mission is "
                                             "idle; 0 = never (a person starts it)")
    planning_altitude: float = param(unit="m", range=(0.5, 10.0),
                                     description="height of the paths priced with A*")
    speed: float = param(unit="m/s", range=(0.05, 5.0), lo_open=True,
                         description="average speed along a planned path")
    land_s: float = param(unit="s", range=(0.0, 600.0),
                          description="precision landing on a pad, search included")
    takeoff_s: float = param(unit="s", range=(0.0, 600.0),
                             description="take-off from a pad to the cruise altitude")
    mission_time_s: float = param(unit="s", range=(1.0, 36000.0),
                                  description="the contest's time limit, from START")
    battery_reserve: float = param(range=(0.0, 1.0),
                                   description="charge kept at the end of the sequence")
    drain_per_s: float = param(unit="1/s", range=(1e-6, 1.0),
                               description="charge used per second of flight")
    plan_timeout_s: float = param(unit="s", range=(0.1, 600.0),
                                  description="wait this long for all the A* answers")


__all__ = ["FIELD_SOURCE", "MissionParams", "OperatorParams", "PadsParams", "RobotsParams"]
