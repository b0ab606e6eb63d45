"""What every mission script of the scenarios does with the companion, written once.

A :class:`Pilot` is a client of the companion's public interface only (it never reads the
simulator): it follows ``flight_control``'s health report, holds the arm client and the
clients of the services and actions it names (from :mod:`interfaces.graph`), and offers
the three steps every script takes: wait until flight control reports ready, arm (retried
as the mission does, :func:`flight_control.clients.arm`), and send a goal and wait for its
result (:meth:`Pilot.goal`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from flight_control.clients import ARM_RETRY_S, arm, arm_client
from flight_control.goal_checks import NO_POSITION_MESSAGE
from flight_control.health import MODULE_HEALTH
from interfaces import graph
from runtime import ActionClient, Node

READY_POLL_S = 0.1  # s between looks at the health report while waiting for ready


@dataclass(frozen=True)
class GoalReply:
    """How a goal ended: accepted or not, and its result (success and message)."""

    accepted: bool
    result: Any  # the action's Result

    @property
    def success(self) -> bool:
        return self.accepted and bool(self.result.success)

    @property
    def message(self) -> str:
        """The server's message (a rejection's reason when the goal was not accepted)."""
        return str(self.result.message)

    @property
    def text(self) -> str:
        """The message, ``rejected: <reason>`` for a goal the server did not accept."""
        return self.message if self.accepted else f"rejected: {self.message}"


class Pilot(Node):
    """A mission script: ``uses`` names the services and actions it calls (their clients
    are in :attr:`clients`, by name, created in that order after the arm client)."""

    def __init__(self, name: str, uses: Sequence[graph.Service | graph.Action],
                 **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.health_level: int | None = None  # flight control's, None before any report
        #: flight control's last report's values (``armed``, ``streaming``... as text)
        self.health_values: dict[str, str] = {}
        self.arm_client = arm_client(self)
        self.clients: dict[str, Any] = {
            entry.name: (ActionClient(self, entry.type, entry.name)
                         if isinstance(entry, graph.Action)
                         else self.create_client(entry.type, entry.name))
            for entry in uses}
        health = graph.HEALTH["flight_control"]
        self.create_subscription(health.type, health.name, self._on_health,
                                 health.subscriber_qos)

    def _on_health(self, msg: Any) -> None:
        self.health_level = int(msg.level)
        self.health_values = {kv.key: kv.value for m in msg.modules for kv in m.values}

    @property
    def flying(self) -> bool:
        """Flight control reports the vehicle armed and its setpoint stream on: a flight
        is under way (a restarted script takes it over instead of taking off again)."""
        v = self.health_values
        return v.get("armed") == "true" and v.get("streaming") == "true"

    async def wait_ready(self, timeout_s: float) -> bool:
        """Until flight control reports OK (True) or ``timeout_s`` has passed (False)."""
        waited = 0.0
        while self.health_level != MODULE_HEALTH.LEVEL_OK:
            if waited >= timeout_s:
                return False
            await self.sleep(READY_POLL_S)
            waited += READY_POLL_S
        return True

    async def arm_vehicle(self, attempts: int) -> str | None:
        """Arm, ``attempts`` times at most: None once armed, else the last refusal."""
        return await arm(self, self.arm_client, attempts)

    async def goal(self, action: graph.Action, goal: Any, attempts: int = 1) -> GoalReply:
        """Send ``goal`` to ``action`` and wait for its result. A goal rejected for want of
        a position estimate is sent again, up to ``attempts`` times ``ARM_RETRY_S`` apart,
        as arming is: a process starved of CPU can leave the FCU's estimate invalid for a
        moment. Any other rejection ends it at once."""
        if attempts < 1:
            raise ValueError(f"{action.name}: attempts must be 1 or more, got {attempts}")
        client = self.clients[action.name]
        reply = GoalReply(False, None)
        for attempt in range(attempts):
            if attempt:
                await self.sleep(ARM_RETRY_S)
            handle = await client.send_goal_async(goal)
            response = await handle.get_result_async()
            reply = GoalReply(bool(handle.accepted), response.result)
            if reply.accepted or reply.message != NO_POSITION_MESSAGE:
                break
            self.get_logger().warning(f"goal {reply.text} (attempt {attempt + 1}/{attempts})")
        return reply


__all__ = ["GoalReply", "Pilot"]
