"""Actions in rclpy's shape, built from services and topics as ROS 2 builds them.

An action ``name`` is the services ``name/_action/send_goal``, ``.../cancel_goal`` and
``.../get_result`` and the topics ``.../feedback`` and ``.../status``, with the composed
types that rosidl generates, so the wire looks like ROS 2's.

Server side: ``goal_callback(goal)`` accepts or rejects (a ``Rejection("why")`` rejects
with a reason), ``execute_callback(goal_handle)`` runs the goal and returns the result; it
may be ``async`` and ``await node.sleep(...)`` or other futures, so long goals never
block the executor. The result of a rejected goal, asked for with ``get_result``, has
status UNKNOWN and the reason in its ``message`` field when the Result type has one.
"""

from __future__ import annotations

import hashlib
import inspect
import traceback
from collections.abc import Callable, Coroutine
from dataclasses import dataclass
from enum import Enum, IntEnum
from typing import Any, TypeVar

import numpy as np

import interfaces
from interfaces.qos import qos_profile_action_status_default, qos_profile_default
from runtime.clock import Time, seconds_to_ns
from runtime.errors import GoalCanceled, RuntimeApiError
from runtime.future import Future, first_done
from runtime.node import Node

T = TypeVar("T")


class GoalStatus(IntEnum):
    """action_msgs/msg/GoalStatus values."""

    UNKNOWN = 0
    ACCEPTED = 1
    EXECUTING = 2
    CANCELING = 3
    SUCCEEDED = 4
    CANCELED = 5
    ABORTED = 6


TERMINAL = frozenset({GoalStatus.SUCCEEDED, GoalStatus.CANCELED, GoalStatus.ABORTED})


class GoalResponse(Enum):
    REJECT = 1
    ACCEPT = 2


class CancelResponse(Enum):
    REJECT = 1
    ACCEPT = 2


class CancelReturnCode(IntEnum):
    """action_msgs/srv/CancelGoal response codes."""

    ERROR_NONE = 0
    ERROR_REJECTED = 1
    ERROR_UNKNOWN_GOAL_ID = 2
    ERROR_GOAL_TERMINATED = 3


@dataclass(frozen=True)
class Rejection:
    """What a goal callback returns to reject a goal and say why."""

    reason: str


class ActionStateError(RuntimeApiError):
    """A goal moved to a state its current state does not allow."""


_ALLOWED = {
    GoalStatus.ACCEPTED: {GoalStatus.EXECUTING, GoalStatus.CANCELING},
    GoalStatus.EXECUTING: {
        GoalStatus.CANCELING,
        GoalStatus.SUCCEEDED,
        GoalStatus.ABORTED,
    },
    GoalStatus.CANCELING: {GoalStatus.CANCELED, GoalStatus.SUCCEEDED, GoalStatus.ABORTED},
}


def _uuid_key(goal_id: Any) -> bytes:
    return bytes(np.asarray(goal_id.uuid, dtype=np.uint8))


def _uuid_msg(key: bytes) -> Any:
    return interfaces.new(
        "unique_identifier_msgs/msg/UUID", uuid=np.frombuffer(key, dtype=np.uint8).copy()
    )


def _action_names(node: Node, name: str) -> dict[str, str]:
    base = node.resolve_name(name)
    return {
        part: f"{base}/_action/{part}"
        for part in ("send_goal", "cancel_goal", "get_result", "feedback", "status")
    }


class ServerGoalHandle:
    """One accepted goal on the server."""

    def __init__(self, server: ActionServer, goal_id: bytes, request: Any, stamp: Time) -> None:
        self._server = server
        self.goal_id = goal_id
        self.request = request
        self.stamp = stamp
        self.status = GoalStatus.ACCEPTED
        self.result: Any = None
        self._cancel_requested: Future[None] = Future(server._node.context.loop)

    @property
    def is_active(self) -> bool:
        return self.status not in TERMINAL

    @property
    def is_cancel_requested(self) -> bool:
        return self.status is GoalStatus.CANCELING

    def _to(self, status: GoalStatus) -> None:
        if status not in _ALLOWED.get(self.status, set()):
            raise ActionStateError(
                f"goal {self.goal_id.hex()[:8]}: cannot go from {self.status.name} to "
                f"{status.name}"
            )
        self.status = status
        if status is GoalStatus.CANCELING:
            self._cancel_requested.set_result(None)
        self._server.publish_status()

    async def unless_canceled(self, future: Future[T]) -> T:
        """``future``'s result, or :class:`GoalCanceled` if this goal's cancel comes first.

        A server that dies mid-call never answers: an execute callback that awaits it
        plainly would keep its goal running for ever, deaf to the cancel.
        """
        if not future.done() and not self.is_cancel_requested:
            await first_done(future, self._cancel_requested, loop=self._server._node.context.loop)
        if not future.done():
            raise GoalCanceled(f"goal {self.goal_id.hex()[:8]} canceled while it waited")
        return future.result()

    def execute(self) -> None:
        """Start executing (the default when a goal is accepted)."""
        self._server.start_execution(self)

    def publish_feedback(self, feedback: Any) -> None:
        self._server.publish_feedback(self, feedback)

    def succeed(self) -> None:
        self._to(GoalStatus.SUCCEEDED)

    def abort(self) -> None:
        self._to(GoalStatus.ABORTED)

    def canceled(self) -> None:
        self._to(GoalStatus.CANCELED)


GoalCallback = Callable[[Any], "GoalResponse | Rejection"]


class ActionServer:
    """Serves one action. See the module docstring for the callbacks."""

    def __init__(
        self,
        node: Node,
        action_type: interfaces.ActionType | str,
        action_name: str,
        execute_callback: Callable[[ServerGoalHandle], Any],
        *,
        goal_callback: GoalCallback | None = None,
        cancel_callback: Callable[[ServerGoalHandle], CancelResponse] | None = None,
        handle_accepted_callback: Callable[[ServerGoalHandle], None] | None = None,
        result_timeout: float = 900.0,
    ) -> None:
        self.action_type = (
            interfaces.get_action(action_type) if isinstance(action_type, str) else action_type
        )
        self._node = node
        self._names = _action_names(node, action_name)
        self.action_name = node.resolve_name(action_name)
        self._execute = execute_callback
        self._goal_callback = goal_callback or (lambda _goal: GoalResponse.ACCEPT)
        self._cancel_callback = cancel_callback or (lambda _h: CancelResponse.ACCEPT)
        self._handle_accepted = handle_accepted_callback or (lambda h: h.execute())
        self._result_timeout_ns = seconds_to_ns(result_timeout)
        self._goals: dict[bytes, ServerGoalHandle] = {}
        self._rejections: dict[bytes, str] = {}
        self._result_waiters: dict[bytes, list[Future[Any]]] = {}
        at = self.action_type
        self._send_goal = node.create_service(at.SendGoal, self._names["send_goal"],
                                              self._on_send_goal)
        self._cancel = node.create_service(interfaces.cancel_goal_service(),
                                           self._names["cancel_goal"], self._on_cancel)
        self._get_result = node.create_service(at.GetResult, self._names["get_result"],
                                               self._on_get_result)
        self._feedback_pub = node.create_publisher(at.FeedbackMessage, self._names["feedback"],
                                                   qos_profile_default)
        self._status_pub = node.create_publisher("action_msgs/msg/GoalStatusArray",
                                                 self._names["status"],
                                                 qos_profile_action_status_default)

    # services ----------------------------------------------------------------------------
    def _on_send_goal(self, request: Any, response: Any) -> Any:
        key = _uuid_key(request.goal_id)
        verdict = self._goal_callback(request.goal)
        response.stamp = self._node.now().to_msg()
        if isinstance(verdict, Rejection) or verdict is GoalResponse.REJECT:
            reason = verdict.reason if isinstance(verdict, Rejection) else "rejected"
            self._rejections[key] = reason
            self._node.get_logger().info(f"{self.action_name}: goal rejected: {reason}")
            response.accepted = False
            return response
        if key in self._goals:
            response.accepted = False
            self._rejections[key] = "duplicate goal id"
            return response
        handle = ServerGoalHandle(self, key, request.goal, self._node.now())
        self._goals[key] = handle
        response.accepted = True
        self.publish_status()
        self._node.context.loop.call_soon(
            lambda: self._handle_accepted(handle),
            (self._node.get_name(), "action", self.action_name),
        )
        return response

    def _on_cancel(self, request: Any, response: Any) -> Any:
        key = _uuid_key(request.goal_info.goal_id)
        stamp_ns = Time.from_msg(request.goal_info.stamp).nanoseconds
        everything = key == bytes(16)
        if not everything and key not in self._goals:
            response.return_code = CancelReturnCode.ERROR_UNKNOWN_GOAL_ID
            return response
        candidates = [
            h
            for k, h in self._goals.items()
            if (everything and stamp_ns == 0)
            or k == key
            or (stamp_ns and h.stamp.nanoseconds <= stamp_ns)
        ]
        active = [h for h in candidates if h.is_active]
        if not active:
            response.return_code = CancelReturnCode.ERROR_GOAL_TERMINATED
            return response
        canceling = []
        for handle in active:
            if handle.status is GoalStatus.CANCELING or (
                self._cancel_callback(handle) is CancelResponse.ACCEPT
            ):
                if handle.status is not GoalStatus.CANCELING:
                    handle._to(GoalStatus.CANCELING)
                info = interfaces.new("action_msgs/msg/GoalInfo",
                                      goal_id=_uuid_msg(handle.goal_id),
                                      stamp=handle.stamp.to_msg())
                canceling.append(info)
        response.goals_canceling = canceling
        response.return_code = (
            CancelReturnCode.ERROR_NONE if canceling else CancelReturnCode.ERROR_REJECTED
        )
        return response

    def _on_get_result(self, request: Any, response: Any) -> Any:
        key = _uuid_key(request.goal_id)
        handle = self._goals.get(key)
        if handle is None:
            response.status = GoalStatus.UNKNOWN
            result = interfaces.new(self.action_type.Result)
            if key in self._rejections and hasattr(result, "message"):
                result.message = self._rejections[key]
            response.result = result
            return response
        if handle.result is not None:  # terminal, and execute has returned its result
            return self._result_response(handle)
        waiter: Future[Any] = Future(self._node.context.loop)
        self._result_waiters.setdefault(key, []).append(waiter)
        return waiter

    def _result_response(self, handle: ServerGoalHandle) -> Any:
        return interfaces.new(self.action_type.GetResult.Response, status=int(handle.status),
                              result=handle.result)

    # execution ---------------------------------------------------------------------------
    def start_execution(self, handle: ServerGoalHandle) -> None:
        if handle.status is GoalStatus.ACCEPTED:
            handle._to(GoalStatus.EXECUTING)
        try:
            outcome = self._execute(handle)
        except Exception as exc:  # as rclpy: a failing goal aborts, the executor goes on
            self._node.get_logger().error(f"{self.action_name}: execute failed: {exc!r}")
            self._finish_with(handle, None)
            return
        if inspect.iscoroutine(outcome):
            task = self._node.create_task(self._guarded(outcome))
            task.add_done_callback(lambda t: self._finish(handle, t))
        else:
            self._finish_with(handle, outcome)

    async def _guarded(self, execution: Coroutine[Any, Any, Any]) -> Any:
        try:
            return await execution
        except Exception as exc:  # with where it failed: a bug in a node, to be fixed
            where = "".join(traceback.format_exception(exc)[-4:]).rstrip()
            self._node.get_logger().error(f"{self.action_name}: execute failed: {exc!r}\n{where}")
            return None

    def _finish(self, handle: ServerGoalHandle, task: Future[Any]) -> None:
        if task.cancelled():  # the node is being destroyed: nobody is left to tell
            return
        self._finish_with(handle, task.result())

    def _finish_with(self, handle: ServerGoalHandle, result: Any) -> None:
        if result is None or getattr(result, "__msgtype__", None) != interfaces.type_name(
            self.action_type.Result
        ):
            if result is not None:
                self._node.get_logger().error(
                    f"{self.action_name}: execute returned {result!r}, not a Result"
                )
            result = interfaces.new(self.action_type.Result)
            if handle.is_active:
                handle.status = GoalStatus.ABORTED
        elif handle.is_active:
            self._node.get_logger().warning(
                f"{self.action_name}: goal left {handle.status.name} by execute; aborting it"
            )
            handle.status = GoalStatus.ABORTED
        handle.result = result
        self.publish_status()
        for waiter in self._result_waiters.pop(handle.goal_id, []):
            waiter.set_result(self._result_response(handle))
        loop = self._node.context.loop
        loop.call_at(
            loop.clock.now().nanoseconds + self._result_timeout_ns,
            lambda: self._expire(handle.goal_id),
            (self._node.get_name(), "action", self.action_name),
        )

    def _expire(self, key: bytes) -> None:
        self._goals.pop(key, None)
        self.publish_status()

    def publish_feedback(self, handle: ServerGoalHandle, feedback: Any) -> None:
        msg = interfaces.new(self.action_type.FeedbackMessage, goal_id=_uuid_msg(handle.goal_id),
                             feedback=feedback)
        self._feedback_pub.publish(msg)

    def publish_status(self) -> None:
        statuses = [
            interfaces.new(
                "action_msgs/msg/GoalStatus",
                goal_info=interfaces.new("action_msgs/msg/GoalInfo",
                                         goal_id=_uuid_msg(h.goal_id), stamp=h.stamp.to_msg()),
                status=int(h.status),
            )
            for h in self._goals.values()
        ]
        self._status_pub.publish(
            interfaces.new("action_msgs/msg/GoalStatusArray", status_list=statuses)
        )

    def goal_handles(self) -> list[ServerGoalHandle]:
        return list(self._goals.values())

    def destroy(self) -> None:
        for entity in (self._send_goal, self._cancel, self._get_result, self._feedback_pub,
                       self._status_pub):
            entity.destroy()


class ClientGoalHandle:
    """The client's view of a goal it sent."""

    def __init__(self, client: ActionClient, goal_id: bytes, accepted: bool, stamp: Time) -> None:
        self._client = client
        self.goal_id = goal_id
        self.accepted = accepted
        self.stamp = stamp
        self.status = GoalStatus.ACCEPTED if accepted else GoalStatus.UNKNOWN

    def get_result_async(self) -> Future[Any]:
        """Future of the GetResult response (``.status``, ``.result``)."""
        return self._client.get_result_async(self)

    def cancel_goal_async(self) -> Future[Any]:
        """Future of the CancelGoal response (``.return_code``, ``.goals_canceling``)."""
        return self._client.cancel_goal_async(self)


class ActionClient:
    """Sends goals to an action server and follows their feedback and status."""

    def __init__(
        self, node: Node, action_type: interfaces.ActionType | str, action_name: str
    ) -> None:
        self.action_type = (
            interfaces.get_action(action_type) if isinstance(action_type, str) else action_type
        )
        self._node = node
        self.action_name = node.resolve_name(action_name)
        names = _action_names(node, action_name)
        at = self.action_type
        self._send_goal = node.create_client(at.SendGoal, names["send_goal"])
        self._cancel = node.create_client(interfaces.cancel_goal_service(), names["cancel_goal"])
        self._get_result = node.create_client(at.GetResult, names["get_result"])
        self._feedback_sub = node.create_subscription(
            at.FeedbackMessage, names["feedback"], self._on_feedback, qos_profile_default
        )
        self._status_sub = node.create_subscription(
            "action_msgs/msg/GoalStatusArray", names["status"], self._on_status,
            qos_profile_action_status_default,
        )
        self._feedback_callbacks: dict[bytes, Callable[[Any], None]] = {}
        self._handles: dict[bytes, ClientGoalHandle] = {}
        # status seen for goals sent but not yet answered (status can overtake the answer)
        self._early_status: dict[bytes, GoalStatus | None] = {}
        self._goal_count = 0

    def _new_goal_id(self) -> bytes:
        self._goal_count += 1
        node = self._node
        seed = (f"{node.get_fully_qualified_name()}{getattr(node, 'instance_tag', '')}|"
                f"{self.action_name}|{self._goal_count}")
        return hashlib.blake2b(seed.encode(), digest_size=16).digest()

    def server_is_ready(self) -> bool:
        return self._send_goal.service_is_ready()

    def wait_for_server(self, timeout_sec: float | None = None) -> bool:
        return self._send_goal.wait_for_service(timeout_sec)

    def send_goal_async(
        self, goal: Any, feedback_callback: Callable[[Any], None] | None = None
    ) -> Future[ClientGoalHandle]:
        """Send ``goal``; the future completes with a ClientGoalHandle (accepted or not)."""
        key = self._new_goal_id()
        request = interfaces.new(self.action_type.SendGoal.Request, goal_id=_uuid_msg(key),
                                 goal=goal)
        if feedback_callback is not None:
            self._feedback_callbacks[key] = feedback_callback
        outer: Future[ClientGoalHandle] = Future(self._node.context.loop)
        self._early_status[key] = None

        def on_response(f: Future[Any]) -> None:
            early = self._early_status.pop(key, None)
            if f.exception() is not None:
                outer.set_exception(f.exception())  # type: ignore[arg-type]
                return
            response = f.result()
            handle = ClientGoalHandle(self, key, bool(response.accepted),
                                      Time.from_msg(response.stamp))
            if handle.accepted:
                handle.status = early or handle.status
                self._handles[key] = handle
            else:
                self._feedback_callbacks.pop(key, None)
            outer.set_result(handle)

        self._send_goal.call_async(request).add_done_callback(on_response)
        return outer

    def get_result_async(self, handle: ClientGoalHandle) -> Future[Any]:
        request = interfaces.new(self.action_type.GetResult.Request,
                                 goal_id=_uuid_msg(handle.goal_id))
        future = self._get_result.call_async(request)

        def done(f: Future[Any]) -> None:
            if f.exception() is None and handle.accepted:
                handle.status = GoalStatus(f.result().status)
                self._feedback_callbacks.pop(handle.goal_id, None)

        future.add_done_callback(done)
        return future

    def cancel_goal_async(self, handle: ClientGoalHandle) -> Future[Any]:
        info = interfaces.new("action_msgs/msg/GoalInfo", goal_id=_uuid_msg(handle.goal_id))
        request = interfaces.new(interfaces.cancel_goal_service().Request, goal_info=info)
        return self._cancel.call_async(request)

    def _on_feedback(self, msg: Any) -> None:
        callback = self._feedback_callbacks.get(_uuid_key(msg.goal_id))
        if callback is not None:
            callback(msg)

    def _on_status(self, msg: Any) -> None:
        for status in msg.status_list:
            key = _uuid_key(status.goal_info.goal_id)
            handle = self._handles.get(key)
            if handle is not None:
                handle.status = GoalStatus(status.status)
            elif key in self._early_status:
                self._early_status[key] = GoalStatus(status.status)

    def destroy(self) -> None:
        for entity in (self._send_goal, self._cancel, self._get_result, self._feedback_sub,
                       self._status_sub):
            entity.destroy()
