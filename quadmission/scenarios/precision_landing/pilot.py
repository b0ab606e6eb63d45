"""A mission script for one precision-landing episode: arm, take off, precision_land.

Like :mod:`quadmission.scenarios.square.pilot`, it is a :class:`~quadmission.scenarios.pilot.Pilot`:
a client of the companion's public interface only (flight control's health, arm and
takeoff, and ``precision_land``). It never reads the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import interfaces
from interfaces import graph
from quadmission.scenarios.pilot import Pilot

TAKEOFF = graph.TAKEOFF.interface()
PRECISION_LAND = graph.PRECISION_LAND.interface()
ARM_ATTEMPTS = 3


@dataclass(frozen=True)
class EpisodeOutcome:
    success: bool
    step: str  # "ready", "arm", "takeoff", "precision_land"
    message: str
    result_code: int | None = None  # PrecisionLand RESULT_*
    land_started_ns: int | None = None
    land_ended_ns: int | None = None


class LandingPilot(Pilot):
    """Arm, take off to ``altitude`` [m], then land precisely on ``pad_id`` expected at
    ``pad_position`` (map frame [m]), searching ``search_radius`` [m] around it when its
    marker is not in view (0: the node's default)."""

    def __init__(self, pad_id: int, pad_position: tuple[float, float, float], *,
                 altitude: float, search_radius: float = 0.0, ready_timeout_s: float = 20.0,
                 **kwargs: Any) -> None:
        super().__init__("landing_pilot", (graph.TAKEOFF, graph.PRECISION_LAND), **kwargs)
        self.pad_id = pad_id
        self.pad_position = pad_position
        self.altitude = altitude
        self.search_radius = search_radius
        self.ready_timeout_s = ready_timeout_s
        self.step = "ready"
        self.outcome: EpisodeOutcome | None = None
        self.create_task(self._run())

    @property
    def done(self) -> bool:
        return self.outcome is not None

    async def _run(self) -> None:
        if not await self.wait_ready(self.ready_timeout_s):
            self.outcome = EpisodeOutcome(False, self.step, "flight control not ready")
            return
        self.step = "arm"
        refused = await self.arm_vehicle(ARM_ATTEMPTS)
        if refused is not None:
            self.outcome = EpisodeOutcome(False, self.step, f"arm: {refused}")
            return
        self.step = "takeoff"
        reply = await self.goal(graph.TAKEOFF, interfaces.new(TAKEOFF.Goal, altitude=self.altitude))
        if not reply.success:
            self.outcome = EpisodeOutcome(False, self.step, f"takeoff: {reply.message}")
            return
        self.step = "precision_land"
        started = self.now().nanoseconds
        x, y, z = self.pad_position
        goal = interfaces.new(PRECISION_LAND.Goal, pad_id=self.pad_id,
                              pad_position=interfaces.new("geometry_msgs/msg/Point", x=x, y=y,
                                                          z=z),
                              search_radius=self.search_radius)
        reply = await self.goal(graph.PRECISION_LAND, goal)
        self.outcome = EpisodeOutcome(reply.success, self.step, reply.message,
                                      int(reply.result.result), started, self.now().nanoseconds)


__all__ = ["EpisodeOutcome", "LandingPilot"]
