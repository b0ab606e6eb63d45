"""The action base of the flight-control layer: what takeoff, reach, turn and land share,
written once (Aerostack2's ``as2_behavior`` base is the model).

:class:`BehaviourServer` serves each :class:`MotionAction`:

- goal checks: the vehicle checks the action needs (:class:`Needs`), then the action's
  own; a problem rejects the goal with its sentence as the reason;
- preemption: a newer motion goal (or arm/disarm) takes control; the running goal is
  aborted with "preempted by a newer goal" and leaves the setpoint to the newcomer;
- cancel: the setpoint holds where the vehicle is (and offboard is asked for again when
  the FCU left it, e.g. during NAV_LAND); the goal ends CANCELED;
- timeout: ``timeout_factor * expected + timeout_margin_s`` with the behaviour's expected
  duration, or the action's fixed timeout when it has none; the setpoint then holds;
- feedback at ``feedback_rate_hz``; the behaviour steps at ``setpoint_rate_hz``;
- the FCU commands a behaviour asks for, through :class:`FcuCommands` (the retry
  protocol of :mod:`flight_control.command_protocol`), answered in the next observation;
- the result: each :class:`Outcome` mapped to the action's ``RESULT_*`` code, ``success``
  and a message that says what happened.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import interfaces
from flight_control.behaviours import (
    BEHAVIOUR_OUTCOMES,
    OFFBOARD,
    Behaviour,
    CommandReply,
    CommandRequest,
    Observation,
    Setpoint,
)
from flight_control.command_protocol import CommandProtocol
from flight_control.goal_checks import GoalProblem, VehicleState, check_vehicle, nav_state_text
from flight_control.params import FlightControlParams
from flight_control.policy import Outcome
from interfaces import graph
from interfaces.px4 import CommandResult
from runtime import (
    ActionServer,
    GoalResponse,
    Node,
    Rejection,
    ServerGoalHandle,
)

NS_PER_S = 1_000_000_000


def _ns(seconds: float) -> int:
    return round(seconds * NS_PER_S)


class FcuCommands:
    """Sends FCU commands on /fcu/command and drives each one's
    :class:`~flight_control.command_protocol.CommandProtocol` with the acks of
    /fcu/command_ack and the node's clock."""

    def __init__(self, node: Node, params: FlightControlParams) -> None:
        self._node = node
        self._params = params
        self._running: list[CommandProtocol] = []
        command, ack = graph.FCU_COMMAND, graph.FCU_COMMAND_ACK
        self._pub = node.create_publisher(command.type, command.name, command.qos)
        node.create_subscription(ack.type, ack.name, self._on_ack, ack.subscriber_qos)

    def _on_ack(self, msg: Any) -> None:
        now_ns = self._node.now().nanoseconds
        for protocol in self._running:
            if protocol.command == int(msg.command):
                protocol.on_ack(int(msg.result), now_ns)

    async def run(self, request: CommandRequest, timeout_s: float = 0.0,
                  stop: Callable[[], bool] | None = None) -> CommandProtocol:
        """Send ``request`` until the protocol is done; ``timeout_s`` 0: the parameter.

        ``stop`` is asked before every send and wait: when it says True (the goal that
        wanted the command was preempted, canceled or timed out) the command is dropped,
        never sent again, and the protocol comes back not done."""
        timeout = timeout_s if timeout_s > 0.0 else self._params.command_timeout_s
        protocol = CommandProtocol(request.command, attempts=self._params.command_attempts,
                                   timeout_ns=_ns(timeout))
        log = self._node.get_logger()
        self._running.append(protocol)
        try:
            while True:
                if stop is not None and stop():
                    log.info(f"{request.command.name}: dropped, the goal that asked for it "
                             f"ended")
                    return protocol
                now_ns = self._node.now().nanoseconds
                if protocol.poll(now_ns):
                    if protocol.sent > 1:
                        why = ("no ack" if protocol.result != CommandResult.TEMPORARILY_REJECTED
                               else "temporarily rejected")
                        log.warning(f"{request.command.name}: {why}, sending again "
                                    f"(attempt {protocol.sent}/{protocol.attempts})")
                    self._pub.publish(interfaces.new(
                        graph.FCU_COMMAND.type,
                        header=interfaces.new("std_msgs/msg/Header",
                                              stamp=self._node.now().to_msg()),
                        command=int(request.command), param1=request.param1,
                        param2=request.param2))
                if protocol.done:
                    break
                wait_ns = min(_ns(self._params.period_s), protocol.deadline_ns - now_ns)
                await self._node.sleep(max(0, wait_ns) / NS_PER_S)
        finally:
            self._running.remove(protocol)
        log.info(protocol.describe())
        return protocol


class Vehicle(Protocol):
    """What the server needs from the node: the observation and the setpoint stream."""

    setpoint: Setpoint | None  # what the stream sends; None: not streaming

    def observe(self, reply: CommandReply | None = None) -> Observation | None:
        """Now, with ``reply``; None before the first position."""
        ...

    def vehicle_state(self) -> VehicleState | None: ...


@dataclass(frozen=True)
class Needs:
    """The vehicle checks an action needs before its own goal checks."""

    armed: bool = True
    flying: bool = False
    offboard: bool = False
    battery: bool = True  # a critical battery rejects the goal (not for land)


@dataclass(frozen=True)
class MotionAction:
    """What differs between the motion actions; the server does the rest."""

    action: interfaces.ActionType
    name: str  # its key in interfaces.graph.FLIGHT_CONTROL_ACTIONS
    needs: Needs
    check: Callable[[Any], GoalProblem | None]  # the goal's own checks
    start: Callable[[Any, Observation, Setpoint], Behaviour[Any]]  # goal, now, streamed
    feedback: Callable[[Any], Any]  # the behaviour's feedback -> the action's Feedback
    finish: Callable[[Any, Any, Observation], str]  # fill the Result; the summary sentence
    codes: Mapping[Outcome, str]  # outcome -> the Result's RESULT_* constant
    timeout_s: float = 0.0  # when the behaviour has no expected duration

    def __post_init__(self) -> None:
        missing = [o.name for o in Outcome if o in BEHAVIOUR_OUTCOMES and o not in self.codes]
        if missing:
            raise ValueError(f"{self.name}: no result code for {', '.join(missing)}")


class BehaviourServer:
    """Serves motion actions for ``vehicle`` on ``node``; see the module docstring."""

    def __init__(self, node: Node, vehicle: Vehicle, commands: FcuCommands,
                 params: FlightControlParams) -> None:
        self.node = node
        self.vehicle = vehicle
        self.commands = commands
        self.params = params
        self._token = 0
        self.servers: dict[str, ActionServer] = {}

    def take_control(self) -> int:
        """A new owner of the setpoint: the running goal, if any, is preempted."""
        self._token += 1
        return self._token

    def serve(self, spec: MotionAction) -> ActionServer:
        name = graph.FLIGHT_CONTROL_ACTIONS[spec.name].name
        server = ActionServer(self.node, spec.action, name,
                              lambda handle: self._execute(spec, handle),
                              goal_callback=lambda goal: self._check(spec, goal))
        self.servers[spec.name] = server
        return server

    def _check(self, spec: MotionAction, goal: Any) -> GoalResponse | Rejection:
        n = spec.needs
        critical = self.params.battery_critical_warning if n.battery else None
        problem = check_vehicle(self.vehicle.vehicle_state(), battery_critical_warning=critical,
                                need_armed=n.armed, need_flying=n.flying,
                                need_offboard=n.offboard) or spec.check(goal)
        return GoalResponse.ACCEPT if problem is None else Rejection(problem.message)

    async def _execute(self, spec: MotionAction, handle: ServerGoalHandle) -> Any:
        token = self.take_control()
        vehicle, period_s = self.vehicle, self.params.period_s
        obs = vehicle.observe()
        if obs is None:
            return self._end(spec, handle, None, 0, Outcome.LOST_CONTROL, "no position")
        if vehicle.setpoint is None:
            vehicle.setpoint = Setpoint.hold(obs.position, obs.yaw)
        behaviour = spec.start(handle.request, obs, vehicle.setpoint)
        expected = behaviour.expected_s
        timeout_ns = _ns(spec.timeout_s if expected is None else
                         self.params.timeout_factor * expected + self.params.timeout_margin_s)
        start_ns = self.node.now().nanoseconds
        feedback_every = max(1, round(self.params.setpoint_rate_hz
                                      / self.params.feedback_rate_hz))
        reply: CommandReply | None = None
        tick = 0

        def goal_over() -> bool:  # a command asked for by this goal is dropped after it
            return (token != self._token or handle.is_cancel_requested
                    or self.node.now().nanoseconds - start_ns > timeout_ns)

        while True:
            now_ns = self.node.now().nanoseconds
            obs = vehicle.observe(reply) or obs
            if token != self._token:
                outcome, reason = Outcome.PREEMPTED, "preempted by a newer goal"
                break
            if handle.is_cancel_requested:
                outcome, reason = await self._cancel(obs)
                break
            step = behaviour.step(obs, now_ns)
            if step.setpoint is not None:
                vehicle.setpoint = step.setpoint
            if tick % feedback_every == 0:
                handle.publish_feedback(spec.feedback(step.feedback))
            tick += 1
            if step.outcome is not None:
                outcome, reason = step.outcome, step.reason
                break
            if now_ns - start_ns > timeout_ns:
                vehicle.setpoint = Setpoint.hold(obs.position, obs.yaw)
                outcome, reason = Outcome.TIMEOUT, ""
                break
            if step.command is not None:
                done = await self.commands.run(step.command, stop=goal_over)
                reply = CommandReply(step.command, done.accepted, done.describe())
                continue
            await self.node.sleep(period_s)
        return self._end(spec, handle, obs, timeout_ns, outcome, reason)

    async def _cancel(self, obs: Observation) -> tuple[Outcome, str]:
        """Hold where the vehicle is; take offboard back when the FCU left it."""
        self.vehicle.setpoint = Setpoint.hold(obs.position, obs.yaw)
        if obs.armed and not obs.in_control:
            done = await self.commands.run(OFFBOARD)
            if not done.accepted:
                return Outcome.LOST_CONTROL, f"canceled, but {done.describe()}"
        return Outcome.CANCELED, ""

    def _end(self, spec: MotionAction, handle: ServerGoalHandle, obs: Observation | None,
             timeout_ns: int, outcome: Outcome, reason: str) -> Any:
        """The goal's final state and its Result for ``outcome``."""
        result = interfaces.new(spec.action.Result)
        summary = spec.finish(handle.request, result, obs) if obs is not None else ""
        result.result = getattr(result, spec.codes[outcome])
        result.success = outcome is Outcome.SUCCEEDED
        if outcome is Outcome.SUCCEEDED:
            handle.succeed()
        elif outcome is Outcome.CANCELED:
            handle.canceled()
        else:
            handle.abort()
        if outcome is Outcome.LOST_CONTROL and not reason:
            state = self.vehicle.vehicle_state()
            nav = "unknown" if state is None else nav_state_text(int(state.nav_state))
            reason = f"lost offboard control (FCU {nav})"
        elif outcome is Outcome.TIMEOUT:
            reason = f"timed out after {timeout_ns / NS_PER_S:.1f} s: {summary}"
        result.message = reason or summary
        self.node.get_logger().info(f"{spec.name} {outcome.value}: {result.message}")
        return result


__all__ = ["BehaviourServer", "FcuCommands", "MotionAction", "Needs", "Vehicle"]
