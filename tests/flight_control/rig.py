"""The flight-control node on a scripted FCU, with a pilot that uses its services and
actions: an in-process executor in simulated time, no MuJoCo."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import interfaces
from flight_control.flight_control_node import (
    ARM,
    DISARM,
    LAND,
    REACH,
    TAKEOFF,
    TURN,
    FlightControlNode,
)
from runtime import ActionClient, DeterministicExecutor, Node, qos_profile_default
from runtime.future import Future
from tests.flight_control.scripted_fcu import ScriptedFcu

FIELD = {"field_min": [0.0, 0.0, 0.0], "field_max": [10.0, 8.0, 4.0]}


@dataclass
class Rig:
    ex: DeterministicExecutor
    fc: FlightControlNode
    fcu: ScriptedFcu
    pilot: Node
    clients: dict[str, Any] = field(default_factory=dict)
    health: list[Any] = field(default_factory=list)

    def t(self) -> float:
        return self.ex.now().nanoseconds / 1e9

    def wait(self, future: Future[Any], limit_s: float) -> Any:
        assert self.ex.spin_until_future_complete(future, timeout_sec=limit_s), \
            f"no answer within {limit_s} s of simulated time"
        return future.result()

    def call(self, service: str, limit_s: float = 10.0, **fields: Any) -> Any:
        client = self.clients[service]
        return self.wait(client.call_async(interfaces.new(client.srv_type.Request, **fields)),
                         limit_s)

    def send(self, action: str, feedback: list[Any] | None = None, **fields: Any) -> Any:
        client: ActionClient = self.clients[action]
        cb = None if feedback is None else (lambda m: feedback.append(m.feedback))
        goal = interfaces.new(client.action_type.Goal, **fields)
        return self.wait(client.send_goal_async(goal, feedback_callback=cb), 1.0)

    def result(self, handle: Any, limit_s: float = 30.0) -> Any:
        """GetResult's response (``.status``, ``.result``)."""
        return self.wait(handle.get_result_async(), limit_s)


def reach_goal(x: float, y: float, z: float) -> dict[str, Any]:
    return {"target": interfaces.new("geometry_msgs/msg/Pose", position=interfaces.new(
        "geometry_msgs/msg/Point", x=x, y=y, z=z)), "stop_at_target": True}


def make_rig(flying_at: tuple[float, float, float] | None = None,
             **overrides: Any) -> Rig:
    ex = DeterministicExecutor()
    fcu = ScriptedFcu(context=ex.context)
    if flying_at is not None:
        fcu.fly_at(flying_at)
    fc = FlightControlNode(context=ex.context, parameter_overrides=FIELD | overrides)
    pilot = Node("pilot", context=ex.context)
    rig = Rig(ex, fc, fcu, pilot)
    rig.clients = {
        "arm": pilot.create_client(ARM, "/flight_control/arm"),
        "disarm": pilot.create_client(DISARM, "/flight_control/disarm"),
        "takeoff": ActionClient(pilot, TAKEOFF, "/flight_control/takeoff"),
        "reach": ActionClient(pilot, REACH, "/flight_control/reach"),
        "turn": ActionClient(pilot, TURN, "/flight_control/turn"),
        "land": ActionClient(pilot, LAND, "/flight_control/land"),
    }
    pilot.create_subscription("quadmission_interfaces/msg/HealthReport",
                              "/flight_control/health", rig.health.append, qos_profile_default)
    for node in (fcu, fc, pilot):
        ex.add_node(node)
    ex.spin_for(0.5)  # status and odometry arrive
    return rig
