"""The simulated operator at the ground station, for unattended runs.

It does what the contest's operator did (seed 003, 3.1) and nothing more: it sends START
(``start_after_s`` after the mission shows ``idle``), receives the robot's pictures on
``/mission/robot``, reads the points table the robot carries (the arena's, passed by the
app as parameters: the simulated operator reads the printed table off the pictures), and
answers on ``/mission/command`` with the landing sequence. Beyond the seed, the sequence is
the best one (:func:`fsm.operator.solve_exact`): every leg is priced with the A* planner
(``/navigation/plan_path`` at ``planning_altitude``, from above the robot and between
pads), the budget is the lesser of the contest time left (``/mission/state.elapsed``)
and the battery above the reserve (``/fcu/status``). ``decision`` keeps the problem, the
exact tour and the greedy one for the report. The ground station's page can send the same
command instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

import interfaces
from fsm.operator import Problem, Tour, budget_s, leg_costs, solve_exact, solve_greedy
from fsm.params import FIELD_SOURCE, OperatorParams, PadsParams, RobotsParams
from interfaces import graph
from runtime import Node, ParameterError

PLAN_PATH = graph.PLAN_PATH.interface()
_PLANNED: Any = PLAN_PATH.Response
COMMAND: Any = graph.MISSION_COMMAND.interface()
PHASE_IDLE = 0  # MissionState.PHASE_IDLE


@dataclass(frozen=True)
class Decision:
    """What the operator decided and from what: for the report."""

    robot: int
    problem: Problem
    lengths_m: list[list[float]]  # A* path lengths, start then pads (inf: no path)
    exact: Tour
    greedy: Tour
    time_left_s: float
    battery_remaining: float
    decided_at_s: float


class OperatorNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("operator", **kwargs)
        self.params = self.declare_params(OperatorParams)
        try:
            pads = self.declare_params(PadsParams)
            robots = self.declare_params(RobotsParams)
        except ParameterError as exc:
            raise ParameterError(f"{exc}; {FIELD_SOURCE} (and robot_ids, robot_points)"
                                 ) from None
        self.pads = pads.positions()
        n = len(pads.pad_ids)
        if len(robots.robot_points) != n * len(robots.robot_ids):
            raise ParameterError(f"operator.robot_points: {len(robots.robot_points)} values "
                                 f"for {len(robots.robot_ids)} robots x {n} pads")
        self.tables = {robot: dict(zip(pads.pad_ids, robots.robot_points[i * n:(i + 1) * n],
                                       strict=True))
                       for i, robot in enumerate(robots.robot_ids)}
        self.pictures: list[Any] = []  # RobotFound messages received (with the images)
        self.decision: Decision | None = None
        self.refusal = ""  # why no sequence was sent, when it could not be
        self._state: Any = None
        self._status: Any = None
        self._idle_since_ns: int | None = None
        self._started = False
        self._deciding = False
        self.plan_client = self.create_client(PLAN_PATH, graph.PLAN_PATH.name)
        self.command_pub, self.proposal_pub = (
            self.create_publisher(t.type, t.name, t.qos)
            for t in (graph.MISSION_COMMAND, graph.SEQUENCE_PROPOSAL))
        for topic, callback in ((graph.MISSION_ROBOT, self._on_robot),
                                (graph.MISSION_STATE, self._on_state),
                                (graph.FCU_STATUS, self._on_status)):
            self.create_subscription(topic.type, topic.name, callback, topic.subscriber_qos)
        if self.params.start_after_s > 0.0:
            self.create_timer(0.1, self._maybe_start)

    # -- START --------------------------------------------------------------------------
    def _on_state(self, msg: Any) -> None:
        self._state = msg

    def _on_status(self, msg: Any) -> None:
        self._status = msg

    def _maybe_start(self) -> None:
        if self._started or self._state is None or int(self._state.phase) != PHASE_IDLE:
            return
        now = self.now().nanoseconds
        if self._idle_since_ns is None:
            self._idle_since_ns = now
        if (now - self._idle_since_ns) / 1e9 >= self.params.start_after_s:
            self._started = True
            self.send(COMMAND.COMMAND_START, "simulated operator: start")

    def send(self, command: int, reason: str = "", sequence: Any = None) -> None:
        msg = interfaces.new(COMMAND, command=command, reason=reason)
        msg.header.stamp = self.now().to_msg()
        if sequence is not None:
            msg.sequence = sequence
        self.command_pub.publish(msg)

    # -- the pictures, then the sequence ---------------------------------------------------
    def _on_robot(self, msg: Any) -> None:
        self.pictures.append(msg)
        if not self._deciding and self.decision is None:
            self._deciding = True
            self.create_task(self._decide(msg))

    async def _decide(self, robot: Any) -> None:
        marker = int(robot.marker_id)
        table = self.tables.get(marker)
        if table is None:
            self.refusal = f"robot {marker} carries no known points table"
            self.get_logger().error(f"operator: {self.refusal}")
            return
        p = robot.pose.position
        start = (float(p.x), float(p.y))
        ids = tuple(self.pads)
        lengths = await self._lengths([start, *(self.pads[i] for i in ids)])
        cost = leg_costs(lengths, speed=self.params.speed, land_s=self.params.land_s,
                         takeoff_s=self.params.takeoff_s)
        time_left, battery = self._time_left_s(), self._battery()
        budget = budget_s(time_left_s=time_left,
                          battery_remaining=1.0 if math.isnan(battery) else battery,
                          battery_reserve=self.params.battery_reserve,
                          drain_per_s=self.params.drain_per_s)
        problem = Problem(ids, tuple(int(table[i]) for i in ids), cost, budget)
        exact, greedy = solve_exact(problem), solve_greedy(problem)
        self.decision = Decision(marker, problem, lengths.tolist(), exact, greedy, time_left,
                                 battery, self.now().seconds)
        self.get_logger().info(
            f"operator: robot {marker}, budget {budget:.0f} s: sequence {list(exact.pads)} "
            f"({exact.points} points, {exact.cost:.0f} s); greedy {list(greedy.pads)} "
            f"({greedy.points} points)")
        sequence = interfaces.new(graph.SEQUENCE_PROPOSAL.type, pad_ids=list(exact.pads),
                                  pad_points=[table[i] for i in exact.pads],
                                  robot_marker_id=marker)
        sequence.header.stamp = self.now().to_msg()
        self.proposal_pub.publish(sequence)
        if not exact.pads:  # the mission would refuse an empty sequence and wait for one
            why = (f"no pad fits the budget of {budget:.0f} s" if np.isfinite(lengths[0, 1:]).any()
                   else "no path from the robot to any pad")
            self.send(COMMAND.COMMAND_RETURN_HOME, f"{why} for robot {marker}")
            return
        self.send(COMMAND.COMMAND_SEQUENCE, f"best of {len(ids)} pads for robot {marker}",
                  sequence)

    async def _lengths(self, xy: list[tuple[float, float]]) -> np.ndarray:
        """A* path lengths [m] between every two places (inf where there is no path);
        paths are taken as symmetric, so each pair is asked once. The first place is the
        robot's: where the planner cannot start above it (a robot against a wall or an
        obstacle is inside the vehicle's clearance; the vehicle saw it from beside it),
        its legs are priced by the straight line."""
        n = len(xy)
        lengths = np.zeros((n, n))
        z = self.params.planning_altitude
        for i in range(n):
            for j in range(i + 1, n):
                request = interfaces.new(PLAN_PATH.Request)
                request.start = interfaces.point(*xy[i], z)
                request.goal = interfaces.point(*xy[j], z)
                response = await self.plan_client.call_async(request)
                if response.success:
                    value = float(response.length)
                elif i == 0 and response.result == _PLANNED.RESULT_START_OCCUPIED:
                    value = math.dist(xy[0], xy[j])
                else:
                    value = math.inf
                lengths[i, j] = lengths[j, i] = value
        return lengths

    def _time_left_s(self) -> float:
        elapsed = 0.0
        if self._state is not None:
            elapsed = self._state.elapsed.sec + self._state.elapsed.nanosec / 1e9
        return max(self.params.mission_time_s - elapsed, 0.0)

    def _battery(self) -> float:
        return math.nan if self._status is None else float(self._status.battery_remaining)


__all__ = ["Decision", "OperatorNode"]
