"""The simulated FCU's face on the ROS graph: the uXRCE-DDS agent behind a serial link.

On a real drone the flight controller talks uORB, a serial line carries the topics, and
the Micro XRCE-DDS agent on the companion computer turns them into ROS 2 topics under
``/fmu/in`` and ``/fmu/out``. :class:`FcuAgentNode` plays that part: every message in
either direction crosses the :class:`~sim.fcu.link.Link` (latency, jitter, spikes, loss,
wire time for its CDR size, FIFO order), so a companion node sees exactly what it would
see over the wire and nothing else.

- FCU -> companion: the firmware calls :meth:`FcuAgentNode.send` at its own tick; the
  message is published on ``/fmu/out/<topic>`` at its delivery time (QoS as PX4's
  uXRCE-DDS client: best effort, transient local).
- companion -> FCU: ``/fmu/in/<topic>`` samples go into :class:`FcuInbox` with their
  delivery time; the firmware takes those that have arrived with :meth:`FcuInbox.take`
  (polled, at its own tick). A topic registered with :meth:`FcuAgentNode.on_arrival` is
  instead handed to its consumer at the delivery time itself (event-driven, as the
  modified firmware of seed 000 section 4.3: "consumed by requesting processes as soon
  as they are available").
- The agent also answers the FCU's own time-sync requests on the companion's clock, the
  way the XRCE agent does, so the FCU can estimate the offset it reports in
  ``/fmu/out/timesync_status``.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import interfaces
from interfaces.px4.topics import FMU_IN, FMU_OUT, XRCE_SESSION, XRCE_TIMESYNC_BYTES, FmuTopic
from runtime import Node
from runtime.errors import ParameterError
from sim.fcu.link import Link, LinkDirection

#: What the agent carries, keyed by short name: the /fmu topics plus the modelled XRCE
#: session's Timesync exchange ("timesync": request in, reply out; not PX4 topics).
AGENT_OUT: dict[str, FmuTopic] = {**FMU_OUT, "timesync": XRCE_SESSION["reply"]}
AGENT_IN: dict[str, FmuTopic] = {**FMU_IN, "timesync": XRCE_SESSION["request"]}


@dataclass(frozen=True)
class Arrival:
    """A companion message as the FCU receives it."""

    delivery_ns: int  # simulated time it arrived at the FCU
    topic: str  # the /fmu/in topic name without the prefix
    msg: Any


@dataclass(frozen=True)
class AgentTimesyncReply:
    """The agent's answer to an FCU time-sync request, as the FCU receives it."""

    delivery_ns: int
    request_fcu_us: int  # the FCU's clock when it sent the request
    agent_time_ns: int  # the companion's clock when the agent answered


class FcuInbox:
    """Companion messages in delivery order (the serial line is FIFO)."""

    def __init__(self) -> None:
        self._queue: deque[Arrival] = deque()
        self._timesync: deque[AgentTimesyncReply] = deque()
        self.received = 0

    def put(self, arrival: Arrival) -> None:
        self._queue.append(arrival)
        self.received += 1

    def take(self, now_ns: int) -> list[Arrival]:
        """Every message delivered at or before ``now_ns``, oldest first."""
        out = []
        while self._queue and self._queue[0].delivery_ns <= now_ns:
            out.append(self._queue.popleft())
        return out

    def put_timesync(self, reply: AgentTimesyncReply) -> None:
        self._timesync.append(reply)

    def take_timesync(self, now_ns: int) -> list[AgentTimesyncReply]:
        out = []
        while self._timesync and self._timesync[0].delivery_ns <= now_ns:
            out.append(self._timesync.popleft())
        return out


class FcuAgentNode(Node):
    """Publishes what the FCU sends and queues what the companion sends, across the link."""

    def __init__(self, link: Link, *, session_topics: bool = True, **kwargs: Any) -> None:
        """``session_topics``: the modelled XRCE session's Timesync exchange on the graph
        (:data:`XRCE_SESSION`, for the companion's ``timesync_source: exchange``); without
        it the agent carries the /fmu topics alone, as PX4's does."""
        super().__init__("fcu_agent", **kwargs)
        self.link = link
        self.inbox = FcuInbox()
        outs, ins = (AGENT_OUT, AGENT_IN) if session_topics else (FMU_OUT, FMU_IN)
        self._publishers = {
            short: self.create_publisher(topic.type, topic.name, topic.qos)
            for short, topic in outs.items()
        }
        self._subscriptions = [
            self.create_subscription(topic.type, topic.name, self._receiver(short, topic.type),
                                     topic.qos)
            for short, topic in ins.items()
        ]
        self._consumers: dict[str, Callable[[Arrival], None]] = {}
        self.sent = dict.fromkeys(AGENT_OUT, 0)
        self.lost = dict.fromkeys(AGENT_OUT, 0)
        self.clock_offset_ns = 0
        """The companion's clock, as the agent reads it to answer the FCU's time sync,
        minus simulated time (a fault: the companion's clock jumped)."""

    @property
    def malformed(self) -> int:
        """/fmu/in samples the FCU could not parse (dropped, and logged)."""
        return sum(s.malformed for s in self._subscriptions)

    def _receiver(self, topic: str, type_name: str) -> Any:
        def receive(msg: Any) -> None:
            size = interfaces.cdr_size(msg, type_name)  # what the serial line carries
            delivery = self.link.send(LinkDirection.TO_FCU, self.now().nanoseconds, size)
            if delivery is None:
                return
            arrival = Arrival(delivery, topic, msg)
            consumer = self._consumers.get(topic)
            if consumer is None:
                self.inbox.put(arrival)
            else:
                self.context.loop.call_at(delivery, lambda: consumer(arrival),
                                          (self.get_name(), "link", topic))

        return receive

    def on_arrival(self, topic: str, consumer: Callable[[Arrival], None]) -> None:
        """Hand every ``/fmu/in/<topic>`` message to ``consumer`` at its delivery time
        instead of queueing it in :attr:`inbox` (an event-driven consumer on the FCU)."""
        if topic not in AGENT_IN:
            raise ParameterError(f"{topic!r} is not an /fmu/in topic; choose from "
                                 f"{sorted(AGENT_IN)}", key="event_driven_inputs")
        self._consumers[topic] = consumer

    def send(self, topic: str, msg: Any, t_ns: int) -> None:
        """Send ``msg`` from the FCU at ``t_ns``: published on /fmu/out/``topic`` when it
        arrives, or never if the link loses it."""
        publisher = self._publishers[topic]
        interfaces.validate(msg, publisher.type_name)  # the FCU's bug, raised where it is
        delivery = self.link.send(LinkDirection.TO_COMPANION, t_ns,
                                  interfaces.cdr_size(msg, publisher.type_name))
        if delivery is None:
            self.lost[topic] += 1
            return
        self.sent[topic] += 1
        self.context.loop.call_at(delivery, lambda: publisher.publish(msg),
                                  (self.get_name(), "link", topic))

    def unread(self, topic: str) -> bool:
        """Whether /fmu/out/``topic`` has no subscriber and a fixed CDR size: then the
        message need not be built, :meth:`send_unread` accounts for it on the line."""
        publisher = self._publishers[topic]
        return (publisher.get_subscription_count() == 0
                and interfaces.fixed_cdr_size(publisher.type_name) is not None)

    def send_unread(self, topic: str, t_ns: int) -> None:
        """Account for a /fmu/out/``topic`` message nobody subscribes to: it takes its
        time on the serial line (so the other messages queue behind it exactly as if it
        were built) but is neither built nor published."""
        publisher = self._publishers[topic]
        size = interfaces.fixed_cdr_size(publisher.type_name)
        if size is None:
            raise ValueError(f"/fmu/out/{topic}: its size varies; build and send() it")
        delivery = self.link.send(LinkDirection.TO_COMPANION, t_ns, size)
        if delivery is None:
            self.lost[topic] += 1
        else:
            self.sent[topic] += 1

    def request_timesync(self, fcu_time_us: int, t_ns: int) -> None:
        """The FCU asks the agent for its clock (the XRCE-DDS session's time sync)."""
        arrival = self.link.send(LinkDirection.TO_COMPANION, t_ns, XRCE_TIMESYNC_BYTES)
        if arrival is None:
            return

        def answer() -> None:
            now_ns = self.now().nanoseconds
            back = self.link.send(LinkDirection.TO_FCU, now_ns, XRCE_TIMESYNC_BYTES)
            if back is not None:
                self.inbox.put_timesync(AgentTimesyncReply(
                    back, fcu_time_us, now_ns + self.clock_offset_ns))

        self.context.loop.call_at(arrival, answer, (self.get_name(), "link", "xrce_timesync"))
