"""A mission script that flies a square through the flight-control layer.

It is what the navigator and the mission state machine will be: a client of
``/flight_control/*`` and nothing else. It waits for the layer's health report to say
the vehicle is ready, calls ``/flight_control/arm``, then sends the goals in turn:
``takeoff`` to the square's altitude, one ``reach`` per corner (stopping at each), back
to the first corner, and ``land`` with disarm. It never reads the simulator: where the
vehicle really went is the scenario's business (:mod:`quadmission.evaluation.tracking`).

A pilot started while the vehicle flies (its process respawned: ``respawn`` in the launch
file) keeps nothing of the one that died; it learns where the flight is from the topics:
flight control's health says armed with its setpoint stream on, so it neither arms nor
takes off, and ``/fcu/odometry`` says where the vehicle is, so it flies on from the
corner nearest it (one end of the leg it was on), then lands.

Map frame (ENU), metres, seconds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
import numpy.typing as npt

import interfaces
from interfaces import graph
from quadmission.scenarios.pilot import Pilot

TAKEOFF = graph.TAKEOFF.interface()
REACH = graph.REACH.interface()
LAND = graph.LAND.interface()

FloatArray = npt.NDArray[np.float64]


class PilotPhase(Enum):
    """Where the mission script is; the order is the flight's."""

    WAIT_READY = "wait_ready"
    ARM = "arm"
    TAKEOFF = "takeoff"
    SQUARE = "square"
    LAND = "land"
    DONE = "done"
    FAILED = "failed"


@dataclass(frozen=True)
class PilotOutcome:
    """How the mission script ended: whether every step succeeded, and what it said."""

    success: bool
    phase: PilotPhase  # the step that ended it (DONE on success)
    message: str


class SquarePilot(Pilot):
    """Arm, take off to ``altitude``, reach ``corners`` in order at ``speed``, land at
    ``land_speed`` and disarm.

    ``corners``: (N, 3) map-frame points [m]; the flight starts above the take-off
    point, which should be the first corner's x, y (the square closes there).
    """

    def __init__(self, corners: Sequence[Sequence[float]], *, altitude: float,
                 speed: float = 0.0, land_speed: float = 0.0, ready_timeout_s: float = 20.0,
                 arm_attempts: int = 5, goal_attempts: int = 3, **kwargs: Any) -> None:
        super().__init__("square_pilot", (graph.TAKEOFF, graph.REACH, graph.LAND), **kwargs)
        self.corners: FloatArray = np.asarray(corners, dtype=np.float64).reshape(-1, 3)
        if len(self.corners) == 0:
            raise ValueError("SquarePilot: no corners to fly")
        self.altitude = float(altitude)
        self.speed = float(speed)  # m/s, reach cruise speed; 0: the layer's default
        self.land_speed = float(land_speed)  # m/s, descent; 0: the FCU's own landing
        self.ready_timeout_s = ready_timeout_s
        self.arm_attempts = arm_attempts
        self.goal_attempts = goal_attempts  # tries per goal while it is rejected
        self.phase = PilotPhase.WAIT_READY
        self.phase_started_ns: dict[PilotPhase, int] = {PilotPhase.WAIT_READY: 0}
        self.corner_index = 0  # the corner being flown to (during SQUARE)
        self.outcome: PilotOutcome | None = None
        self.position: FloatArray | None = None  # the vehicle's, from /fcu/odometry [m]
        self.resumed_at: int | None = None  # the corner a restarted pilot flew on from
        odometry = graph.FCU_ODOMETRY
        self.create_subscription(odometry.type, odometry.name, self._on_odometry,
                                 odometry.subscriber_qos)
        self.create_task(self._mission())

    def _on_odometry(self, msg: Any) -> None:
        p = msg.pose.pose.position
        self.position = np.array([p.x, p.y, p.z], dtype=np.float64)

    def nearest_corner(self) -> int:
        """The corner nearest the vehicle (0 before any odometry)."""
        if self.position is None:
            return 0
        return int(np.argmin(np.linalg.norm(self.corners - self.position, axis=1)))

    @property
    def done(self) -> bool:
        return self.outcome is not None

    def _enter(self, phase: PilotPhase) -> None:
        self.phase = phase
        self.phase_started_ns[phase] = self.now().nanoseconds
        self.get_logger().info(f"square pilot: {phase.value}")

    def _finish(self, success: bool, message: str) -> None:
        failed_in = self.phase
        self._enter(PilotPhase.DONE if success else PilotPhase.FAILED)
        self.outcome = PilotOutcome(success, PilotPhase.DONE if success else failed_in, message)

    async def _mission(self) -> None:
        if not await self.wait_ready(self.ready_timeout_s):
            self._finish(False, f"flight control not ready after {self.ready_timeout_s:g} s")
            return
        first = 0
        if self.flying:  # a restart in flight: take the flight over where it is
            while self.position is None:  # odometry comes at 100 Hz
                await self.sleep(0.05)
            first = self.resumed_at = self.nearest_corner()
            self.get_logger().info(f"square pilot: the vehicle is flying; on from corner "
                                   f"{first + 1}/{len(self.corners)}")
        else:
            self._enter(PilotPhase.ARM)
            refused = await self.arm_vehicle(self.arm_attempts)
            if refused is not None:
                self._finish(False, f"arm: {refused}")
                return
            self._enter(PilotPhase.TAKEOFF)
            reply = await self.goal(graph.TAKEOFF, interfaces.new(
                TAKEOFF.Goal, altitude=self.altitude), self.goal_attempts)
            if not reply.success:
                self._finish(False, f"takeoff: {reply.text}")
                return
        self._enter(PilotPhase.SQUARE)
        for i in range(first, len(self.corners)):
            corner = self.corners[i]
            self.corner_index = i
            goal = interfaces.new(REACH.Goal, stop_at_target=True, speed=self.speed)
            goal.target.position = interfaces.point(*corner)
            reply = await self.goal(graph.REACH, goal, self.goal_attempts)
            if not reply.success:
                self._finish(False, f"reach corner {i + 1}/{len(self.corners)}: {reply.text}")
                return
        self._enter(PilotPhase.LAND)
        reply = await self.goal(graph.LAND, interfaces.new(LAND.Goal, disarm=True,
                                                          speed=self.land_speed),
                                self.goal_attempts)
        if not reply.success:
            self._finish(False, f"land: {reply.text}")
            return
        self._finish(True, reply.message)


__all__ = ["PilotOutcome", "PilotPhase", "SquarePilot"]
