"""The graph contract (interfaces/graph.py) against the graph the launches really make.

``config/launch/mission.yaml`` and ``square.yaml`` are built in process (the simulator
and every node constructed, no time spun: nodes make their publishers, subscriptions,
services and actions when constructed, as rclpy nodes do; a few seconds), and every
endpoint the transport holds is held against the contract: each one is in it, with its
node at the right end, its type and its QoS; and each end the contract names exists,
unless its node runs only elsewhere (:data:`ELSEWHERE`, each with where). The /fmu side
is the PX4 contract's (interfaces/px4/topics.py), checked by name and type: its ends are
the simulated firmware and the bridge.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from interfaces import graph
from interfaces.px4.topics import FMU_IN, FMU_OUT, XRCE_SESSION
from interfaces.qos import (
    QoSProfile,
    qos_profile_action_status_default,
    qos_profile_default,
    qos_profile_services_default,
)
from runtime import DeterministicExecutor
from runtime.launch import LaunchDescription, launch
from runtime.transport import Endpoint, EndpointKind, InProcessTransport

ROOT = Path(__file__).resolve().parents[4]
LAUNCHES = ("mission.yaml", "square.yaml")  # under config/launch/

#: Nodes the contract names that the launches above do not run, and where they run.
ELSEWHERE = {
    "ground_station": "the operator's page: quadmission sim --gcs, quadmission gcs",
    "scripted_operator": "quadmission sim --scenario mission (the unattended operator)",
    "setpoint_recorder": "quadmission sim --scenario mission|square|navigate (evaluation)",
    "frame_grabber": "quadmission sim --scenario arena-tour",
    "square_status": "quadmission sim --scenario square (the outline for the page)",
    "landing_pilot": "quadmission sim --scenario precision-landing",
    "navigate_pilot": "quadmission sim --scenario navigate",
    "latency_test": "quadmission latency (seed 000's test)",
    "offboard_harness": "quadmission fcu-schedule (hover_flight)",
    "simulator_clock": "a launch over processes (--transport ros2): the simulator's /clock",
    "launch_{process}_clock": "a launch over processes: each node process's lockstep report",
}
#: The QoS of an action's parts (ROS 2's: feedback as topics, status latched).
ACTION_PART_QOS = {"feedback": qos_profile_default,
                   "status": qos_profile_action_status_default}
_PX4 = {t.name: t for t in (*FMU_IN.values(), *FMU_OUT.values(), *XRCE_SESSION.values())}
_PATTERNS = [(re.compile(re.escape(t.name).replace(re.escape("{" + t.field + "}"),
                                                   "([A-Za-z0-9_]+)") + "$"), t)
             for t in graph.TOPICS if isinstance(t, graph.TopicPattern)]

End = tuple[str, str, str]  # (contract entry's name, role, node)


@pytest.fixture(scope="module")
def launched() -> tuple[list[Endpoint], list[Endpoint]]:
    """Every writer's and reader's endpoint of the launches, each built alone."""
    writers: list[Endpoint] = []
    readers: list[Endpoint] = []
    for name in LAUNCHES:
        description = LaunchDescription.from_yaml(ROOT / "config" / "launch" / name)
        executor = DeterministicExecutor()
        assert description.simulator is not None
        description.simulator.build(executor)
        nodes = launch(description, executor)
        transport = executor.context.transport
        assert isinstance(transport, InProcessTransport)
        writers += transport.writer_endpoints()
        readers += transport.reader_endpoints()
        for node in nodes:
            node.destroy_node()
    return writers, readers


def _node(endpoint: Endpoint) -> str:
    return endpoint.node.rsplit("/", 1)[-1]


def _action_part(name: str) -> tuple[graph.Action, str] | None:
    base, sep, part = name.partition("/_action/")
    entry = graph.ENTRIES.get(base)
    return (entry, part) if sep and isinstance(entry, graph.Action) else None


def _topic(name: str, node: str) -> tuple[graph.Topic | None, str]:
    """The contract's topic of ``name`` and ``node`` as the contract names it (a pattern's
    instance, ``launch_companion_clock``, as ``launch_{process}_clock``)."""
    entry = graph.ENTRIES.get(name)
    if isinstance(entry, graph.Topic):
        return entry, node
    for regex, pattern in _PATTERNS:
        if match := regex.match(name):
            named = {n.format_map({pattern.field: match[1]}): n for n in (
                *pattern.publishers, *pattern.subscribers, *pattern.monitors)}
            return pattern, named.get(node, node)
    return None, node


def _topic_end(endpoint: Endpoint, writes: bool) -> Iterator[End | str]:
    """The contract end of one topic endpoint, or what is wrong with it."""
    name, node, qos = endpoint.name, _node(endpoint), endpoint.qos
    if (action := _action_part(name)) is not None:
        entry, part = action
        want_type = (entry.feedback_type if part == "feedback"
                     else "action_msgs/msg/GoalStatusArray")
        want_qos: QoSProfile | None = ACTION_PART_QOS.get(part)
        yield entry.name, "server" if writes else "client", node
    elif name in _PX4:
        if endpoint.type_name != _PX4[name].type:
            yield f"{name}: {node} uses {endpoint.type_name}, the PX4 contract {_PX4[name].type}"
        return
    else:
        topic, node = _topic(name, node)
        if topic is None:
            yield f"{name}: {node}'s topic is not in the contract"
            return
        want_type = topic.type
        if writes:
            want_qos, role = topic.qos, "publisher"
        elif qos == graph.MONITOR_QOS and node in topic.monitors:
            want_qos, role = graph.MONITOR_QOS, "monitor"
        else:
            want_qos, role = topic.subscriber_qos, "subscriber"
        yield topic.name, role, node
    if endpoint.type_name != want_type:
        yield f"{name}: {node} uses {endpoint.type_name}, the contract {want_type}"
    if qos != want_qos:
        yield (f"{name}: {node} {'writes' if writes else 'reads'} with "
               f"{graph.describe_qos(qos)}, the contract says {graph.describe_qos(want_qos)}"
               if want_qos is not None else f"{name}: no such part of an action")


def _service_end(endpoint: Endpoint, serves: bool) -> Iterator[End | str]:
    """The contract end of one half of a service (or of an action's service)."""
    name, node = endpoint.name, _node(endpoint)
    if (action := _action_part(name)) is not None and action[1] in graph.ACTION_SERVICES:
        owner, part = action
        prefix = "action_msgs/srv/CancelGoal" if part == "cancel_goal" else (
            f"{owner.type}_{''.join(w.title() for w in part.split('_'))}")
        yield owner.name, "server" if serves else "client", node
    else:
        entry = graph.ENTRIES.get(name)
        if not isinstance(entry, graph.Service):
            yield f"{name}: {node}'s service is not in the contract"
            return
        prefix = entry.type
        yield entry.name, "server" if serves else "client", node
    half = "_Request" if endpoint.kind is EndpointKind.REQUEST else "_Response"
    if endpoint.type_name != prefix + half:
        yield f"{name}: {node} uses {endpoint.type_name}, the contract {prefix + half}"
    if endpoint.qos != qos_profile_services_default:
        yield f"{name}: {node} uses {graph.describe_qos(endpoint.qos)}, not services default"


def code_ends(writers: list[Endpoint], readers: list[Endpoint]) -> tuple[set[End], list[str]]:
    """Every end the code makes, as the contract would name it, and what is wrong."""
    ends: set[End] = set()
    wrong: list[str] = []
    for endpoints, writes in ((writers, True), (readers, False)):
        for endpoint in endpoints:
            if endpoint.kind is EndpointKind.TOPIC:
                found = _topic_end(endpoint, writes)
            else:  # a request is written by a client, a reply by the server
                found = _service_end(endpoint, writes == (endpoint.kind is EndpointKind.REPLY))
            for item in found:
                if isinstance(item, str):
                    wrong.append(item)
                else:
                    ends.add(item)
    return ends, wrong


def contract_ends() -> set[End]:
    """Every end the contract names."""
    out: set[End] = set()
    for e in graph.ENTRIES.values():
        if isinstance(e, graph.Topic):
            out |= {(e.name, "publisher", n) for n in e.publishers}
            out |= {(e.name, "subscriber", n) for n in e.subscribers}
            out |= {(e.name, "monitor", n) for n in e.monitors}
        else:
            out |= {(e.name, "server", n) for n in e.servers}
            out |= {(e.name, "client", n) for n in e.clients}
    return out


def test_every_endpoint_of_the_launches_is_in_the_contract_as_it_is(
        launched: tuple[list[Endpoint], list[Endpoint]]) -> None:
    ends, wrong = code_ends(*launched)
    wrong += [f"{name}: {node} is a {role} the contract does not name"
              for name, role, node in sorted(ends - contract_ends())]
    assert not wrong, "the launches' graph and interfaces/graph.py disagree:\n" + "\n".join(
        sorted(set(wrong)))


def test_every_end_the_contract_names_is_made_by_a_launch(
        launched: tuple[list[Endpoint], list[Endpoint]]) -> None:
    ends, _ = code_ends(*launched)
    missing = [f"{name}: no {role} {node}" for name, role, node in
               sorted(contract_ends() - ends) if node not in ELSEWHERE]
    assert not missing, ("ends interfaces/graph.py names that no launch makes "
                         "(fix the contract, or list the node's launch in ELSEWHERE):\n"
                         + "\n".join(missing))


def test_the_nodes_run_elsewhere_are_the_contracts_and_not_the_launches(
        launched: tuple[list[Endpoint], list[Endpoint]]) -> None:
    """ELSEWHERE names only nodes the contract has, and none the launches run (their
    ends are checked, not excused)."""
    assert set(ELSEWHERE) <= set(graph.nodes()), set(ELSEWHERE) - set(graph.nodes())
    ran = {_node(e) for e in (*launched[0], *launched[1])}
    assert not ran & set(ELSEWHERE), ran & set(ELSEWHERE)
