"""The mission node and the operator node through their topics, without the simulator:
commands are answered on /mission/events, /mission/state follows the machine, preflight
refuses to start when a module does not answer, and the operator starts the mission."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import interfaces
from fsm.mission_messages import COMMAND
from fsm.mission_node import MissionNode
from fsm.operator_node import OperatorNode
from interfaces import graph
from runtime import DeterministicExecutor, Node, qos_profile_default, qos_profile_latched

PADS = {"pad_ids": [1, 2, 3], "pad_x": [1.5, 3.0, 7.0], "pad_y": [1.5, 7.5, 10.5],
        "start_pad": 1}
KIND: Any = interfaces.get_message("quadmission_interfaces/msg/MissionEvent")


class Station(Node):
    """A ground station page: sends commands, keeps what the mission publishes."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("station", **kwargs)
        self.states: list[Any] = []
        self.events: list[Any] = []
        self.pub = self.create_publisher(COMMAND, graph.MISSION_COMMAND.name, qos_profile_default)
        self.create_subscription(graph.MISSION_STATE.type, graph.MISSION_STATE.name,
                                 self.states.append, qos_profile_latched)
        self.create_subscription(graph.MISSION_EVENTS.type, graph.MISSION_EVENTS.name,
                                 self.events.append, qos_profile_default)

    def send(self, command: int, **fields: Any) -> None:
        self.pub.publish(interfaces.new(COMMAND, command=command, **fields))


@pytest.fixture
def rig() -> tuple[DeterministicExecutor, MissionNode, Station]:
    ex = DeterministicExecutor()
    mission = MissionNode(context=ex.context, parameter_overrides=PADS | {
        "preflight_timeout_s": 2.0})
    station = Station(context=ex.context)
    ex.add_node(mission)
    ex.add_node(station)
    ex.spin_for(0.5)
    return ex, mission, station


def test_state_is_published_and_commands_out_of_place_are_rejected_with_the_reason(
        rig: tuple[DeterministicExecutor, MissionNode, Station]) -> None:
    ex, _, station = rig
    assert station.states and station.states[-1].state == "idle"
    assert station.states[-1].phase == 0  # PHASE_IDLE
    station.send(COMMAND.COMMAND_PAUSE)
    station.send(0)
    ex.spin_for(0.5)
    rejected = [e for e in station.events if e.kind == KIND.KIND_COMMAND_REJECTED]
    assert [e.message.split(":")[0] for e in rejected] == ["PAUSE rejected",
                                                           "unknown command 0"]
    assert "nothing to pause in state idle" in rejected[0].message


def test_preflight_refuses_to_start_naming_every_module_that_did_not_answer(
        rig: tuple[DeterministicExecutor, MissionNode, Station]) -> None:
    ex, mission, station = rig
    station.send(COMMAND.COMMAND_START)
    ex.spin_for(3.0)
    assert [s for _, s in mission.timeline] == ["idle", "preflight", "stopped"]
    reason = station.states[-1].stop_reason
    assert reason.startswith("preflight_failed in preflight")
    for missing in ("navigate server not available", "/flight_control/health did not answer",
                    "/fcu/status did not answer"):
        assert missing in reason
    assert station.states[-1].phase == 10  # PHASE_ABORTED
    assert any(e.kind == KIND.KIND_MODULE_FAULT for e in station.events)


def test_the_operator_starts_the_mission_once_it_shows_idle() -> None:
    ex = DeterministicExecutor()
    mission = MissionNode(context=ex.context, parameter_overrides=PADS)
    operator = OperatorNode(context=ex.context, parameter_overrides=PADS | {
        "robot_ids": [19], "robot_points": [5, 10, 20], "start_after_s": 1.0})
    ex.add_node(mission)
    ex.add_node(operator)
    ex.spin_for(0.8)
    assert mission.mission.state == "idle"
    ex.spin_for(0.6)
    assert mission.mission.state == "preflight"
    assert operator.tables == {19: {1: 5, 2: 10, 3: 20}}


def _operator_answer(robot_xy: tuple[float, float], *, cloud: np.ndarray | None = None,
                     overrides: dict[str, Any] | None = None) -> tuple[list[Any], list[Any]]:
    """The real path finder and operator on a 12 m x 12 m field: a robot seen at
    ``robot_xy``; (the operator's proposals, its commands)."""
    from navigation.cloud_msgs import cloud_msg
    from navigation.path_finder_node import PathFinderNode
    from runtime import Time

    ex = DeterministicExecutor()
    finder = PathFinderNode(context=ex.context, parameter_overrides={
        "field_min": [0.0, 0.0, 0.0], "field_max": [12.0, 12.0, 3.0]})
    operator = OperatorNode(context=ex.context, parameter_overrides=PADS | {
        "robot_ids": [19], "robot_points": [5, 10, 20], "start_after_s": 0.0}
        | (overrides or {}))
    station = Station(context=ex.context)
    proposals: list[Any] = []
    station.create_subscription(graph.SEQUENCE_PROPOSAL.type, graph.SEQUENCE_PROPOSAL.name,
                                proposals.append, qos_profile_latched)
    commands: list[Any] = []
    station.create_subscription(COMMAND, graph.MISSION_COMMAND.name, commands.append,
                                qos_profile_default)
    robot_pub = station.create_publisher(graph.MISSION_ROBOT.type, graph.MISSION_ROBOT.name,
                                         qos_profile_latched)
    for node in (finder, operator, station):
        ex.add_node(node)
    map_pub = station.create_publisher("sensor_msgs/msg/PointCloud2", "/map/points",
                                       qos_profile_default)
    points = np.array([[11.0, 11.0, 0.5]]) if cloud is None else cloud
    map_pub.publish(cloud_msg(points, Time(0).to_msg(), "map"))
    ex.spin_for(0.2)
    robot = interfaces.new("quadmission_interfaces/msg/RobotFound", marker_id=19)
    robot.pose.position.x, robot.pose.position.y = robot_xy
    robot_pub.publish(robot)
    ex.spin_for(3.0)
    return proposals, commands


def test_the_operator_proposes_the_sequence_it_sends_priced_by_the_path_finder() -> None:
    proposals, commands = _operator_answer((2.0, 2.0))
    sent = [c for c in commands if c.command == COMMAND.COMMAND_SEQUENCE]
    assert len(proposals) == 1 and len(sent) == 1
    assert list(proposals[0].pad_ids) == list(sent[0].sequence.pad_ids)
    assert sorted(proposals[0].pad_ids) == [1, 2, 3]  # all three fit the default budget
    assert list(proposals[0].pad_points) == [{1: 5, 2: 10, 3: 20}[p] for p in proposals[0].pad_ids]


def test_a_robot_against_a_wall_is_priced_from_beside_it_not_refused() -> None:
    """The vehicle's clearance from the field's edge holds the robot's place: the planner
    cannot start there, so the legs from it are priced by the straight line (the faults
    campaign: robot 19 parked against the north wall, and the sequence came out empty)."""
    proposals, commands = _operator_answer((1.5, 11.9))  # 0.1 m from the north wall
    sent = [c for c in commands if c.command == COMMAND.COMMAND_SEQUENCE]
    assert len(sent) == 1 and len(proposals) == 1
    assert sorted(sent[0].sequence.pad_ids) == [1, 2, 3]


def test_when_no_pad_fits_the_budget_the_operator_sends_the_vehicle_home() -> None:
    _, commands = _operator_answer((2.0, 2.0), overrides={"mission_time_s": 20.0})
    assert [c.command for c in commands] == [COMMAND.COMMAND_RETURN_HOME]
    assert "no pad fits the budget of 20 s for robot 19" in commands[0].reason


def test_when_no_pad_can_be_reached_the_operator_says_so_and_sends_the_vehicle_home() -> None:
    """A wall across the field between the robot and every pad."""
    wall = np.array([(x, 1.0, z) for x in np.arange(0.05, 12.0, 0.1)
                     for z in np.arange(0.05, 3.0, 0.1)])
    _, commands = _operator_answer((2.0, 0.5), cloud=wall,
                                   overrides={"pad_y": [11.5, 7.5, 10.5]})
    assert [c.command for c in commands] == [COMMAND.COMMAND_RETURN_HOME]
    assert commands[0].reason == "no path from the robot to any pad for robot 19"


def test_the_mission_switches_the_scanner_with_its_states() -> None:
    """The real scanner: off (and off its image topic) while the mission takes off or flies
    between pads, on where it explores or lands on a pad. Each state change asks."""
    from perception.aruco_scanner_node import ArucoScannerNode

    ex = DeterministicExecutor()
    mission = MissionNode(context=ex.context, parameter_overrides=PADS)
    scanner = ArucoScannerNode(context=ex.context)
    camera = Node("camera", context=ex.context)
    image = camera.create_publisher("sensor_msgs/msg/Image", graph.CAMERA_DOWN_RAW.name,
                                    qos_profile_default)
    for node in (mission, scanner, camera):
        ex.add_node(node)
    ex.spin_for(0.5)
    assert scanner.enabled and image.get_subscription_count() == 1
    seen = []
    for state in ("mission.takeoff", "mission.explore", "mission.report_robot",
                  "mission.await_sequence", "mission.pad.navigate", "mission.pad.land",
                  "mission.pad.search", "mission.pad.takeoff", "mission.pad.navigate",
                  "returning.navigate", "returning.land", "completed"):
        mission.state_changed(state)
        ex.spin_for(0.1)
        seen.append(scanner.enabled)
        assert image.get_subscription_count() == int(scanner.enabled), state
    assert seen == [False, True, True, False, False, True, True, False, False, False, True,
                    False]
    # someone else switches it on (a precision landing's own request): the next state
    # change asks again, though it wants what it wanted before
    scanner._set_enabled(True)
    mission.state_changed("stopped")
    ex.spin_for(0.1)
    assert not scanner.enabled


def test_a_scanner_that_comes_up_late_is_switched_as_the_state_wants() -> None:
    """The state changed before the scanner's service was up: the watchdog asks until the
    scanner answers."""
    from perception.aruco_scanner_node import ArucoScannerNode

    ex = DeterministicExecutor()
    mission = MissionNode(context=ex.context, parameter_overrides=PADS)
    ex.add_node(mission)
    ex.spin_for(0.2)
    mission.state_changed("mission.pad.navigate")  # no scanner yet: nobody to ask
    ex.spin_for(0.5)
    scanner = ArucoScannerNode(context=ex.context)
    ex.add_node(scanner)
    assert scanner.enabled
    ex.spin_for(1.0)
    assert not scanner.enabled
