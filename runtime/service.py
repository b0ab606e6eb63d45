"""A service: answers requests with a callback (rclpy's ``Service``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import interfaces
from interfaces.qos import QoSProfile
from runtime.entity import EntityNode, Inbox, sample_message, sender
from runtime.errors import TopicTypeError
from runtime.future import Future
from runtime.transport import Endpoint, EndpointKind, RequestId, Sample

__all__ = ["Service"]


class Service:
    """Answers requests: ``callback(request, response) -> response``.

    The callback may instead return a Future of the response, to answer later (the
    action server's get_result does this while a goal is still running).
    """

    def __init__(
        self,
        node: EntityNode,
        srv_type: interfaces.ServiceType,
        name: str,
        callback: Callable[[Any, Any], Any],
        qos: QoSProfile,
    ) -> None:
        self.srv_type = srv_type
        self.service_name = node.resolve_name(name)
        self.callback = callback
        self._node = node
        self._req_name = interfaces.type_name(srv_type.Request)
        self._rep_name = interfaces.type_name(srv_type.Response)
        transport = node.context.transport
        self._writer = transport.create_writer(
            Endpoint(self.service_name, self._rep_name, qos, EndpointKind.REPLY,
                     node.get_fully_qualified_name())
        )
        self._send = sender(self._writer, self._rep_name)
        self._inbox = Inbox(node, qos, (node.get_name(), "service", self.service_name),
                             self._handle)
        self._reader = transport.create_reader(
            Endpoint(self.service_name, self._req_name, qos, EndpointKind.REQUEST,
                     node.get_fully_qualified_name()),
            self._inbox.on_sample,
        )

    def _handle(self, data: Sample, request_id: RequestId | None) -> None:
        if request_id is None:
            return
        try:
            request = sample_message(data, self._req_name)
        except interfaces.MessageError as exc:
            self._node.get_logger().error(f"malformed request on {self.service_name}: {exc}")
            return
        response = self.callback(request, interfaces.new(self.srv_type.Response))
        if isinstance(response, Future):  # answered later, when the future completes
            response.add_done_callback(lambda f: self._reply_later(f, request_id))
        else:
            self._reply(response, request_id)

    def _reply_later(self, future: Future[Any], request_id: RequestId) -> None:
        if future.cancelled() or future.exception() is not None:
            self._node.get_logger().error(
                f"service {self.service_name}: no answer, the handler failed: "
                f"{'cancelled' if future.cancelled() else repr(future.exception())}")
            return
        self._reply(future.result(), request_id)

    def _reply(self, response: Any, request_id: RequestId) -> None:
        if getattr(response, "__msgtype__", None) != self._rep_name:
            raise TopicTypeError(
                f"service {self.service_name}: callback returned {response!r}, "
                f"expected a {self._rep_name}"
            )
        self._send(response, request_id)

    def destroy(self) -> None:
        self._inbox.closed = True
        self._reader.close()
        self._writer.close()

