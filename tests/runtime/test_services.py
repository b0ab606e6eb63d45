"""Services: request/response round trips, several clients, deferred answers."""

from __future__ import annotations

from typing import Any

import interfaces
from runtime import DeterministicExecutor, Future, Node

ARM = "quadmission_interfaces/srv/Arm"


def test_each_client_gets_its_own_responses(ex: DeterministicExecutor) -> None:
    server = Node("server", context=ex.context)
    seen: list[bool] = []

    def handle(request: Any, response: Any) -> Any:
        seen.append(bool(request.force))
        response.success = bool(request.force)
        response.message = f"call {len(seen)}"
        return response

    server.create_service(ARM, "/arm", handle)
    a = Node("a", context=ex.context).create_client(ARM, "/arm")
    b = Node("b", context=ex.context).create_client(ARM, "/arm")
    fa = a.call_async(interfaces.new(a.srv_type.Request, force=True))
    fb = b.call_async(interfaces.new(b.srv_type.Request, force=False))
    fa2 = a.call_async(interfaces.new(a.srv_type.Request, force=True))
    ex.spin_for(0.1)
    assert seen == [True, False, True]
    assert (fa.result().message, fb.result().message, fa2.result().message) == (
        "call 1", "call 2", "call 3")
    assert fa.result().success and not fb.result().success


def test_a_service_can_answer_later_with_a_future(ex: DeterministicExecutor) -> None:
    server = Node("server", context=ex.context)

    def handle(request: Any, response: Any) -> Future[Any]:
        later: Future[Any] = Future(ex.context.loop)

        def answer() -> None:
            response.success = True
            response.message = f"answered at {ex.now().seconds:.1f}"
            later.set_result(response)

        ex.call_at(ex.now().nanoseconds + 2_000_000_000, answer, ("server", "test", ""))
        return later

    server.create_service(ARM, "/arm", handle)
    client = Node("c", context=ex.context).create_client(ARM, "/arm")
    future = client.call_async(interfaces.new(client.srv_type.Request))
    ex.spin_for(1.0)
    assert not future.done()
    ex.spin_for(1.5)
    assert future.result().message == "answered at 2.0"


def test_service_names_resolve_in_the_node_namespace(ex: DeterministicExecutor) -> None:
    server = Node("fc", context=ex.context, namespace="/flight_control")
    service = server.create_service(ARM, "arm", lambda req, rep: rep)
    assert service.service_name == "/flight_control/arm"
    client = Node("c", context=ex.context).create_client(ARM, "/flight_control/arm")
    assert client.service_is_ready()
