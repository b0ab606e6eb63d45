"""A service client: requests sent, futures completed by the replies (rclpy's ``Client``)."""

from __future__ import annotations

from typing import Any

import interfaces
from interfaces.qos import QoSProfile
from runtime.entity import EntityNode, Inbox, sample_message, sender
from runtime.errors import TopicTypeError
from runtime.future import Future
from runtime.transport import Endpoint, EndpointKind, RequestId, Sample

__all__ = ["Client"]


class Client:
    """Calls a service: ``future = client.call_async(request)``."""

    def __init__(
        self, node: EntityNode, srv_type: interfaces.ServiceType, name: str, qos: QoSProfile
    ) -> None:
        self.srv_type = srv_type
        self.service_name = node.resolve_name(name)
        self._node = node
        self._req_name = interfaces.type_name(srv_type.Request)
        self._rep_name = interfaces.type_name(srv_type.Response)
        self._guid = node.next_guid("client", self.service_name)
        self._sequence = 0
        self._pending: dict[int, Future[Any]] = {}
        transport = node.context.transport
        self._writer = transport.create_writer(
            Endpoint(self.service_name, self._req_name, qos, EndpointKind.REQUEST,
                     node.get_fully_qualified_name())
        )
        self._send = sender(self._writer, self._req_name)
        self._inbox = Inbox(node, qos, (node.get_name(), "client", self.service_name),
                             self._handle)
        self._reader = transport.create_reader(
            Endpoint(self.service_name, self._rep_name, qos, EndpointKind.REPLY,
                     node.get_fully_qualified_name()),
            self._on_reply,
        )

    def _on_reply(self, data: Sample, request_id: RequestId | None) -> None:
        if request_id is not None and request_id.client_guid == self._guid:
            self._inbox.on_sample(data, request_id)

    def _handle(self, data: Sample, request_id: RequestId | None) -> None:
        assert request_id is not None
        future = self._pending.pop(request_id.sequence, None)
        if future is None or future.done():
            return
        try:
            future.set_result(sample_message(data, self._rep_name))
        except interfaces.MessageError as exc:
            future.set_exception(exc)

    def call_async(self, request: Any) -> Future[Any]:
        """Send ``request``; the future completes with the response."""
        actual = getattr(request, "__msgtype__", type(request).__name__)
        if actual != self._req_name:
            raise TopicTypeError(
                f"call to {self.service_name}: expected {self._req_name}, got {actual}"
            )
        self._sequence += 1
        future: Future[Any] = Future(self._node.context.loop)
        self._pending[self._sequence] = future
        try:
            self._send(request, RequestId(self._guid, self._sequence))
        except interfaces.MessageError:
            del self._pending[self._sequence]
            self._sequence -= 1
            raise
        return future

    def service_is_ready(self) -> bool:
        return self._writer.matched_count() > 0

    def wait_for_service(self, timeout_sec: float | None = None) -> bool:
        """Whether a server is there, answered at once: in simulated time nothing appears
        while we wait; over ROS 2 it is what discovery has matched so far."""
        return self.service_is_ready()

    def remove_pending_request(self, future: Future[Any]) -> None:
        for seq, pending in list(self._pending.items()):
            if pending is future:
                del self._pending[seq]

    def destroy(self) -> None:
        self._inbox.closed = True
        self._reader.close()
        self._writer.close()

