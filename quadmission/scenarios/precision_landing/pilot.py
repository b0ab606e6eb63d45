"""A mission script for one precision-landing episode: arm, take off, precision_land.

Like :mod:`quadmission.scenarios.square.pilot`, it is a client of the companion's public interface
only: ``/flight_control/health``, ``/flight_control/arm``, ``/flight_control/takeoff``
and ``/navigation/precision_land``. It never reads the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import interfaces
from runtime import ActionClient, Node, qos_profile_default

ARM = interfaces.get_service("quadmission_interfaces/srv/Arm")
TAKEOFF = interfaces.get_action("quadmission_interfaces/action/Takeoff")
PRECISION_LAND = interfaces.get_action("quadmission_interfaces/action/PrecisionLand")
HEALTH_OK = 0  # ModuleHealth.LEVEL_OK


@dataclass(frozen=True)
class EpisodeOutcome:
    success: bool
    step: str  # "ready", "arm", "takeoff", "precision_land"
    message: str
    result_code: int | None = None  # PrecisionLand RESULT_*
    land_started_ns: int | None = None
    land_ended_ns: int | None = None


class LandingPilot(Node):
    """Arm, take off to ``altitude`` [m], then land precisely on ``pad_id`` expected at
    ``pad_position`` (map frame [m])."""

    def __init__(self, pad_id: int, pad_position: tuple[float, float, float], *,
                 altitude: float, ready_timeout_s: float = 20.0, **kwargs: Any) -> None:
        super().__init__("landing_pilot", **kwargs)
        self.pad_id = pad_id
        self.pad_position = pad_position
        self.altitude = altitude
        self.ready_timeout_s = ready_timeout_s
        self.step = "ready"
        self.outcome: EpisodeOutcome | None = None
        self._health: int | None = None
        self.arm = self.create_client(ARM, "/flight_control/arm")
        self.takeoff = ActionClient(self, TAKEOFF, "/flight_control/takeoff")
        self.precision_land = ActionClient(self, PRECISION_LAND, "/navigation/precision_land")
        self.create_subscription("quadmission_interfaces/msg/HealthReport",
                                 "/flight_control/health", self._on_health, qos_profile_default)
        self.create_task(self._run())

    @property
    def done(self) -> bool:
        return self.outcome is not None

    def _on_health(self, msg: Any) -> None:
        self._health = int(msg.level)

    async def _run(self) -> None:
        waited = 0.0
        while self._health != HEALTH_OK:
            if waited >= self.ready_timeout_s:
                self.outcome = EpisodeOutcome(False, self.step, "flight control not ready")
                return
            await self.sleep(0.1)
            waited += 0.1
        self.step = "arm"
        for _ in range(3):
            response = await self.arm.call_async(interfaces.new(ARM.Request))
            if response.success:
                break
            await self.sleep(1.0)
        else:
            self.outcome = EpisodeOutcome(False, self.step, f"arm: {response.message}")
            return
        self.step = "takeoff"
        handle = await self.takeoff.send_goal_async(
            interfaces.new(TAKEOFF.Goal, altitude=self.altitude))
        result = (await handle.get_result_async()).result
        if not (handle.accepted and result.success):
            self.outcome = EpisodeOutcome(False, self.step, f"takeoff: {result.message}")
            return
        self.step = "precision_land"
        started = self.now().nanoseconds
        x, y, z = self.pad_position
        goal = interfaces.new(PRECISION_LAND.Goal, pad_id=self.pad_id,
                              pad_position=interfaces.new("geometry_msgs/msg/Point", x=x, y=y,
                                                          z=z))
        handle = await self.precision_land.send_goal_async(goal)
        result = (await handle.get_result_async()).result
        self.outcome = EpisodeOutcome(bool(handle.accepted and result.success), self.step,
                                      str(result.message), int(result.result), started,
                                      self.now().nanoseconds)


__all__ = ["EpisodeOutcome", "LandingPilot"]
