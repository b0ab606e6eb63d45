"""Actions: accept/reject with a reason, feedback, result, cancel, status, failures."""

from __future__ import annotations

from typing import Any

import pytest

import interfaces
from runtime import (
    ActionClient,
    ActionServer,
    CancelResponse,
    DeterministicExecutor,
    GoalCanceled,
    GoalStatus,
    Node,
    Rejection,
    ServerGoalHandle,
)
from runtime.action import CancelReturnCode, GoalResponse
from runtime.future import Future

TAKEOFF = interfaces.get_action("quadmission_interfaces/action/Takeoff")


class ClimbServer(Node):
    """Climbs 0.5 m per 0.1 s tick until the goal altitude; honours cancel."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("climber", **kwargs)
        self.cancel_allowed = True
        self.server = ActionServer(
            self, TAKEOFF, "takeoff", self.execute,
            goal_callback=self.check_goal, cancel_callback=self.on_cancel,
        )

    def check_goal(self, goal: Any) -> GoalResponse | Rejection:
        if goal.altitude > 4.0:
            return Rejection(f"altitude {goal.altitude} m is above the 4.0 m ceiling")
        return GoalResponse.ACCEPT

    def on_cancel(self, handle: ServerGoalHandle) -> CancelResponse:
        return CancelResponse.ACCEPT if self.cancel_allowed else CancelResponse.REJECT

    async def execute(self, handle: ServerGoalHandle) -> Any:
        altitude = 0.0
        result = interfaces.new(TAKEOFF.Result)
        while altitude < handle.request.altitude:
            if handle.is_cancel_requested:
                handle.canceled()
                result.message = f"canceled at {altitude} m"
                return result
            await self.sleep(0.1)
            altitude = min(altitude + 0.5, handle.request.altitude)
            handle.publish_feedback(interfaces.new(
                TAKEOFF.Feedback, altitude=altitude,
                distance_left=handle.request.altitude - altitude))
        handle.succeed()
        result.success = True
        result.position.z = altitude
        return result


@pytest.fixture
def pair(ex: DeterministicExecutor) -> tuple[ClimbServer, ActionClient]:
    server = ClimbServer(context=ex.context)
    client = ActionClient(Node("pilot", context=ex.context), TAKEOFF, "/takeoff")
    return server, client


def _send(ex: DeterministicExecutor, client: ActionClient, altitude: float,
          feedback: list[float] | None = None) -> Any:
    goal = interfaces.new(TAKEOFF.Goal, altitude=altitude)
    cb = None if feedback is None else (lambda m: feedback.append(m.feedback.altitude))
    future = client.send_goal_async(goal, feedback_callback=cb)
    assert ex.spin_until_future_complete(future, timeout_sec=1.0)
    return future.result()


def _serve_and_send(ex: DeterministicExecutor, node: Node, name: str, execute: Any) -> Any:
    """``execute`` served by ``node`` on ``name``; a goal sent to it from another node (its
    client-side handle)."""
    ActionServer(node, TAKEOFF, name, execute)
    return _send(ex, ActionClient(Node("pilot", context=ex.context), TAKEOFF, name), 1.0)


def _result_of(ex: DeterministicExecutor, handle: Any, timeout_sec: float = 1.0) -> Any:
    result_future = handle.get_result_async()
    ex.spin_until_future_complete(result_future, timeout_sec=timeout_sec)
    return result_future.result()


def test_goal_feedback_and_result(ex: DeterministicExecutor, pair: Any) -> None:
    _, client = pair
    assert client.wait_for_server()
    feedback: list[float] = []
    handle = _send(ex, client, 1.5, feedback)
    assert handle.accepted
    result_future = handle.get_result_async()
    assert ex.spin_until_future_complete(result_future, timeout_sec=5.0)
    response = result_future.result()
    assert response.status == GoalStatus.SUCCEEDED
    assert response.result.success and response.result.position.z == 1.5
    assert feedback == [0.5, 1.0, 1.5]
    assert handle.status is GoalStatus.SUCCEEDED
    assert ex.now().seconds == pytest.approx(0.3, abs=1e-6)


def test_rejected_goal_says_why(ex: DeterministicExecutor, pair: Any) -> None:
    _, client = pair
    handle = _send(ex, client, 9.0)
    assert not handle.accepted
    result_future = handle.get_result_async()
    ex.spin_until_future_complete(result_future, timeout_sec=1.0)
    assert result_future.result().status == GoalStatus.UNKNOWN
    assert "above the 4.0 m ceiling" in result_future.result().result.message


def test_cancel_stops_a_running_goal(ex: DeterministicExecutor, pair: Any) -> None:
    server, client = pair
    feedback: list[float] = []
    handle = _send(ex, client, 3.0, feedback)
    ex.spin_for(0.25)
    cancel = handle.cancel_goal_async()
    ex.spin_until_future_complete(cancel, timeout_sec=1.0)
    assert cancel.result().return_code == CancelReturnCode.ERROR_NONE
    assert len(cancel.result().goals_canceling) == 1
    result_future = handle.get_result_async()
    ex.spin_until_future_complete(result_future, timeout_sec=5.0)
    assert result_future.result().status == GoalStatus.CANCELED
    assert result_future.result().result.message.startswith("canceled at")
    assert max(feedback) < 3.0
    assert [h.status for h in server.server.goal_handles()] == [GoalStatus.CANCELED]


def test_cancel_can_be_refused_or_come_too_late(ex: DeterministicExecutor, pair: Any) -> None:
    server, client = pair
    server.cancel_allowed = False
    handle = _send(ex, client, 1.0)
    refused = handle.cancel_goal_async()
    ex.spin_until_future_complete(refused, timeout_sec=1.0)
    assert refused.result().return_code == CancelReturnCode.ERROR_REJECTED
    ex.spin_for(1.0)  # the goal finishes
    late = handle.cancel_goal_async()
    ex.spin_until_future_complete(late, timeout_sec=1.0)
    assert late.result().return_code == CancelReturnCode.ERROR_GOAL_TERMINATED


def test_status_topic_tracks_the_goal_on_the_client(ex: DeterministicExecutor, pair: Any) -> None:
    _, client = pair
    handle = _send(ex, client, 1.0)
    ex.spin_for(0.05)
    assert handle.status is GoalStatus.EXECUTING
    ex.spin_for(1.0)
    assert handle.status is GoalStatus.SUCCEEDED


def test_a_failing_execute_aborts_the_goal(ex: DeterministicExecutor) -> None:
    node = Node("broken", context=ex.context)

    def execute(handle: ServerGoalHandle) -> Any:
        return "not a result"

    handle = _serve_and_send(ex, node, "/broken", execute)
    assert _result_of(ex, handle).status == GoalStatus.ABORTED


def test_cancel_of_an_unknown_goal(ex: DeterministicExecutor, pair: Any) -> None:
    _, client = pair
    handle = _send(ex, client, 9.0)  # rejected, so unknown to the server
    cancel = handle.cancel_goal_async()
    ex.spin_until_future_complete(cancel, timeout_sec=1.0)
    assert cancel.result().return_code == CancelReturnCode.ERROR_UNKNOWN_GOAL_ID


def test_an_execute_that_raises_aborts_the_goal_and_the_executor_goes_on(
    ex: DeterministicExecutor,
) -> None:
    node = Node("fragile", context=ex.context)

    async def execute(handle: ServerGoalHandle) -> Any:
        await node.sleep(0.1)
        raise RuntimeError("sensor gone")

    ActionServer(node, TAKEOFF, "/fragile", execute)
    client = ActionClient(Node("pilot", context=ex.context), TAKEOFF, "/fragile")
    handle = _send(ex, client, 1.0)
    result_future = handle.get_result_async()
    assert ex.spin_until_future_complete(result_future, timeout_sec=1.0)
    assert result_future.result().status == GoalStatus.ABORTED
    again = _send(ex, client, 1.0)  # the server still answers
    assert again.accepted


def test_a_goal_waiting_on_a_silent_node_still_hears_its_cancel(ex: DeterministicExecutor) -> None:
    """A service whose node died never answers; ``unless_canceled`` lets the cancel end the
    goal anyway, so the server takes the next goal (a precision landing after flight
    control's restart was refused as "already running" before)."""
    node = Node("waiter", context=ex.context)
    never: Future[Any] = Future(ex.context.loop)  # the dead node's answer
    seen: list[str] = []

    async def execute(handle: ServerGoalHandle) -> Any:
        try:
            await handle.unless_canceled(never)
        except GoalCanceled as canceled:
            seen.append(str(canceled))
            handle.canceled()
        return interfaces.new(TAKEOFF.Result, message="canceled while waiting")

    handle = _serve_and_send(ex, node, "/waiter", execute)
    ex.spin_for(2.0)
    assert handle.status is GoalStatus.EXECUTING  # still waiting: nothing answered
    ex.spin_until_future_complete(handle.cancel_goal_async(), timeout_sec=1.0)
    assert _result_of(ex, handle).status == GoalStatus.CANCELED
    assert len(seen) == 1 and "canceled while it waited" in seen[0]


def test_unless_canceled_returns_the_answer_that_comes_first(ex: DeterministicExecutor) -> None:
    node = Node("answerer", context=ex.context)

    async def execute(handle: ServerGoalHandle) -> Any:
        answer: Future[float] = Future(ex.context.loop)

        def reply() -> None:
            if not answer.done():
                answer.set_result(2.5)

        node.create_timer(0.3, reply)
        altitude = await handle.unless_canceled(answer)
        handle.succeed()
        return interfaces.new(TAKEOFF.Result, success=True, message=f"{altitude}")

    response = _result_of(ex, _serve_and_send(ex, node, "/answerer", execute), 2.0)
    assert response.status == GoalStatus.SUCCEEDED and response.result.message == "2.5"
