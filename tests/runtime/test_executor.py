"""The deterministic executor: timers in simulated time, callback order, tasks, replay."""

from __future__ import annotations

import gc
import weakref
from typing import Any

import pytest

import interfaces
from runtime import ClockError, DeterministicExecutor, Future, Node, qos_profile_default
from runtime.clock import NS_PER_S


def test_timers_fire_at_exact_multiples_of_their_period(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    fired: dict[str, list[int]] = {"a": [], "b": [], "c": []}
    node.create_timer(0.1, lambda: fired["a"].append(ex.now().nanoseconds))
    node.create_timer(0.25, lambda: fired["b"].append(ex.now().nanoseconds))
    node.create_timer(1 / 12, lambda: fired["c"].append(ex.now().nanoseconds))
    ex.spin_for(1.0)
    assert fired["a"] == [k * NS_PER_S // 10 for k in range(1, 11)]
    assert fired["b"] == [250_000_000, 500_000_000, 750_000_000, 1_000_000_000]
    # 12 Hz does not divide a nanosecond grid: 83_333_333 ns, no drift beyond rounding
    assert len(fired["c"]) == 12
    assert fired["c"][-1] == 12 * 83_333_333


def test_timer_cancel_and_reset(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    calls: list[int] = []
    timer = node.create_timer(0.1, lambda: calls.append(ex.now().nanoseconds))
    ex.spin_for(0.25)
    timer.cancel()
    assert timer.is_canceled() and timer.time_until_next_call() is None
    ex.spin_for(1.0)
    assert len(calls) == 2
    timer.reset()  # restarts the period from now (1.25 s)
    ex.spin_for(0.15)
    assert calls[-1] == 1_350_000_000


def test_spin_until_runs_what_is_due_in_order_and_skips_cancelled_calls(
    ex: DeterministicExecutor,
) -> None:
    ran: list[tuple[str, int]] = []

    def call(name: str) -> None:
        ran.append((name, ex.now_ns()))

    ex.call_at(300, lambda: call("c"), ("", "test", "c"))
    ex.call_at(100, lambda: call("a"), ("", "test", "a"))
    ex.call_at(100, lambda: call("b"), ("", "test", "b"))  # same time: in scheduling order
    ex.call_at(200, lambda: call("x"), ("", "test", "x")).cancel()
    ex.call_at(400, lambda: call("y"), ("", "test", "y")).cancel()
    ex.spin_until(300)
    assert ran == [("a", 100), ("b", 100), ("c", 300)]
    assert ex.now_ns() == ex.now().nanoseconds == 300 and ex.callbacks_run == 3
    assert ex.next_event_ns() is None  # the cancelled call after 300 ns is dropped
    ex.spin_until(350)
    assert ex.now_ns() == 350


def test_non_positive_timer_period_is_an_error(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    with pytest.raises(ClockError, match="positive"):
        node.create_timer(0.0, lambda: None)


def test_time_never_runs_backwards(ex: DeterministicExecutor) -> None:
    ex.spin_for(1.0)
    with pytest.raises(ClockError):
        ex.spin_until(500_000_000)
    with pytest.raises(ClockError):
        ex.call_at(0, lambda: None, ("", "test", ""))


def test_message_published_in_a_timer_is_handled_after_it_at_the_same_time(
    ex: DeterministicExecutor,
) -> None:
    node = Node("n", context=ex.context)
    order: list[tuple[str, int]] = []
    pub = node.create_publisher("std_msgs/msg/Int32", "x", qos_profile_default)

    def tick() -> None:
        order.append(("timer", ex.now().nanoseconds))
        pub.publish(interfaces.new("std_msgs/msg/Int32", data=1))
        order.append(("after publish", ex.now().nanoseconds))

    node.create_subscription("std_msgs/msg/Int32", "x",
                             lambda m: order.append(("sub", ex.now().nanoseconds)),
                             qos_profile_default)
    node.create_timer(0.5, tick)
    ex.spin_for(0.5)
    assert order == [("timer", 500_000_000), ("after publish", 500_000_000),
                     ("sub", 500_000_000)]


def test_spin_until_future_complete_times_out_in_simulated_time(
    ex: DeterministicExecutor,
) -> None:
    node = Node("n", context=ex.context)
    client = node.create_client("quadmission_interfaces/srv/Arm", "/nobody")
    assert not client.service_is_ready()
    future = client.call_async(interfaces.new(client.srv_type.Request))
    assert not ex.spin_until_future_complete(future, timeout_sec=2.0)
    assert not future.done()
    assert ex.now().nanoseconds == 2 * NS_PER_S


def test_coroutine_task_awaits_sleep_and_service(ex: DeterministicExecutor) -> None:
    server = Node("server", context=ex.context)

    def arm(request: Any, response: Any) -> Any:
        response.success = True
        response.message = f"armed at {ex.now().seconds:.1f}"
        return response

    server.create_service("quadmission_interfaces/srv/Arm", "arm", arm)
    node = Node("client", context=ex.context)
    client = node.create_client("quadmission_interfaces/srv/Arm", "/arm")

    async def mission() -> str:
        await node.sleep(1.5)
        response = await client.call_async(interfaces.new(client.srv_type.Request))
        return str(response.message)

    task = node.create_task(mission())
    assert ex.spin_until_future_complete(task, timeout_sec=5.0)
    assert task.result() == "armed at 1.5"


class _Relay(Node):
    """Re-publishes /in to /out with a gain from its parameter, every message."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("relay", **kwargs)
        self.gain = self.declare_parameter("gain", 2).value
        self.pub = self.create_publisher("std_msgs/msg/Int32", "/out", qos_profile_default)
        self.create_subscription("std_msgs/msg/Int32", "/in", self.relay, qos_profile_default)

    def relay(self, msg: Any) -> None:
        self.pub.publish(interfaces.new("std_msgs/msg/Int32", data=msg.data * self.gain))


def _run_three_nodes(gain: int) -> tuple[list[Any], list[int]]:
    ex = DeterministicExecutor(config_dir=None, record_trace=True)
    source = Node("source", context=ex.context)
    pub = source.create_publisher("std_msgs/msg/Int32", "/in", qos_profile_default)
    counter = iter(range(1000))
    source.create_timer(0.02, lambda: pub.publish(
        interfaces.new("std_msgs/msg/Int32", data=next(counter))))
    source.create_timer(0.03, lambda: None)
    relay = _Relay(context=ex.context, parameter_overrides={"gain": gain})
    sink = Node("sink", context=ex.context)
    got: list[int] = []
    sink.create_subscription("std_msgs/msg/Int32", "/out", lambda m: got.append(m.data),
                             qos_profile_default)
    for n in (source, relay, sink):
        ex.add_node(n)
    ex.spin_for(1.0)
    assert ex.trace is not None
    return ex.trace, got


def test_same_inputs_give_the_same_callback_trace() -> None:
    trace_a, data_a = _run_three_nodes(gain=3)
    trace_b, data_b = _run_three_nodes(gain=3)
    assert trace_a == trace_b
    assert data_a == data_b == [3 * k for k in range(50)]
    kinds = {(e.node, e.kind) for e in trace_a}
    assert {("source", "timer"), ("relay", "subscription"), ("sink", "subscription")} <= kinds
    # the trace records behaviour: a different parameter changes the data, not the order
    trace_c, data_c = _run_three_nodes(gain=5)
    assert trace_c == trace_a and data_c != data_a


def test_a_cancelled_task_never_resumes(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    steps: list[str] = []

    async def slow() -> None:
        steps.append("start")
        await node.sleep(1.0)
        steps.append("after sleep")

    task = node.create_task(slow())
    ex.spin_for(0.5)
    assert task.cancel() and task.cancelled()
    ex.spin_for(2.0)
    assert steps == ["start"]


def test_a_destroyed_node_stops_everything_it_did(ex: DeterministicExecutor) -> None:
    node = Node("talker", context=ex.context)
    pub = node.create_publisher("std_msgs/msg/Int32", "/x", 10)
    heard: list[int] = []
    Node("listener", context=ex.context).create_subscription(
        "std_msgs/msg/Int32", "/x", lambda m: heard.append(m.data), 10)

    async def keep_talking() -> None:
        for k in range(100):
            pub.publish(interfaces.new("std_msgs/msg/Int32", data=k))
            await node.sleep(0.1)

    node.create_task(keep_talking())
    ex.spin_for(0.25)
    node.destroy_node()
    count = len(heard)
    ex.spin_for(2.0)
    assert len(heard) == count == 3
    with pytest.raises(Exception, match="destroyed"):
        pub.publish(interfaces.new("std_msgs/msg/Int32", data=-1))


def test_a_destroyed_subscription_hears_nothing_more(ex: DeterministicExecutor) -> None:
    talker = Node("talker", context=ex.context)
    pub = talker.create_publisher("std_msgs/msg/Int32", "/x", 10)
    listener = Node("listener", context=ex.context)
    heard: list[int] = []
    sub = listener.create_subscription("std_msgs/msg/Int32", "/x",
                                       lambda m: heard.append(m.data), 10)
    pub.publish(interfaces.new("std_msgs/msg/Int32", data=1))
    ex.spin_for(0.1)
    assert pub.get_subscription_count() == 1
    pub.publish(interfaces.new("std_msgs/msg/Int32", data=2))  # queued, not yet handled
    assert listener.destroy_subscription(sub)
    pub.publish(interfaces.new("std_msgs/msg/Int32", data=3))
    ex.spin_for(0.1)
    assert heard == [1]
    assert pub.get_subscription_count() == 0
    assert not listener.destroy_subscription(sub)  # already gone
    assert not talker.destroy_subscription(sub)  # never the talker's


def test_a_node_forgets_its_finished_sleeps(ex: DeterministicExecutor) -> None:
    """A node that sleeps in a loop for a whole mission keeps only its pending sleeps:
    nothing of a finished one stays alive (the node once kept every sleep it made, and
    each new sleep scanned them all)."""
    node = Node("sleeper", context=ex.context)
    finished = weakref.ref(node.sleep(0.1))
    pending = node.sleep(10.0)
    ex.spin_for(1.0)
    gc.collect()
    assert finished() is None
    assert not pending.done()
    node.destroy_node()
    ex.spin_for(20.0)
    assert not pending.done()


def test_a_service_whose_deferred_answer_fails_logs_and_keeps_serving(
    ex: DeterministicExecutor, caplog: pytest.LogCaptureFixture
) -> None:
    server = Node("server", context=ex.context)
    calls: list[bool] = []

    def handle(request: Any, response: Any) -> Any:
        calls.append(bool(request.force))
        if request.force:  # answer later, and fail doing so
            later: Future[Any] = Future(ex.context.loop)
            ex.call_at(ex.now().nanoseconds + 100_000_000,
                       lambda: later.set_exception(RuntimeError("handler exploded")),
                       ("server", "test", ""))
            return later
        response.success = True
        return response

    server.create_service("quadmission_interfaces/srv/Arm", "/arm", handle)
    client = Node("c", context=ex.context).create_client("quadmission_interfaces/srv/Arm", "/arm")
    failed = client.call_async(interfaces.new(client.srv_type.Request, force=True))
    ex.spin_for(1.0)
    assert not failed.done()
    assert "handler exploded" in caplog.text
    ok = client.call_async(interfaces.new(client.srv_type.Request, force=False))
    assert ex.spin_until_future_complete(ok, timeout_sec=1.0) and ok.result().success


def test_a_stopped_node_runs_nothing_more_and_the_others_run_on(
        ex: DeterministicExecutor) -> None:
    """A node stopped (a fault: its process died) fires no timer and takes no message;
    the node beside it is unaffected, and its messages to the stopped node are lost."""
    talker, listener = Node("talker", context=ex.context), Node("listener", context=ex.context)
    ticks: list[int] = []
    heard: list[int] = []
    pub = talker.create_publisher("std_msgs/msg/Int32", "/n", qos_profile_default)
    talker.create_timer(0.1, lambda: (ticks.append(ex.now_ns()),
                                      pub.publish(interfaces.new("std_msgs/msg/Int32",
                                                                 data=len(ticks)))))
    listener.create_subscription("std_msgs/msg/Int32", "/n", lambda m: heard.append(m.data),
                                 qos_profile_default)
    ex.spin_for(0.55)
    assert heard == [1, 2, 3, 4, 5]
    ex.stop_node("listener")
    ex.spin_for(0.5)
    assert heard == [1, 2, 3, 4, 5] and len(ticks) == 10
    assert ex.stopped_nodes == {"listener"}
    with pytest.raises(ValueError, match=r"no node 'nobody' to stop .*listener, talker"):
        ex.stop_node("nobody")
