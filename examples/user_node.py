"""Your own ROS 2 node beside the stack: plain rclpy and the built message packages.

Run it while a mission flies as processes on ROS 2:

    quadmission launch config/launch/mission.yaml --transport ros2 &
    .venv/bin/python examples/user_node.py

It prints the mission's state and the drone's odometry as they come, sends the operator
command START on /mission/command and prints the mission's answer from /mission/events
(accepted before the mission starts, rejected with the reason once it runs). It exits 0
once it has seen STATES states, ODOMETRY odometry messages and the answer, 1 after
TIMEOUT seconds without them. With --graph it then prints the ROS 2 graph as rclpy sees
it: each node (``node: /name``) and each topic with its types (``topic: /name type``):

    python examples/user_node.py [--states 3] [--odometry 3] [--timeout 120] [--graph]
"""

import argparse
import sys
import time

import rclpy
from nav_msgs.msg import Odometry
from quadmission_interfaces.msg import MissionCommand, MissionEvent, MissionState
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data

ANSWERS = {MissionEvent.KIND_COMMAND_ACCEPTED: "accepted",
           MissionEvent.KIND_COMMAND_REJECTED: "rejected"}


class MissionWatcher(Node):
    def __init__(self) -> None:
        super().__init__("mission_watcher",  # on the simulator's /clock, as our nodes are
                         parameter_overrides=[Parameter("use_sim_time", value=True)])
        self.states = self.odometry = 0
        self.answer = ""
        self.create_subscription(MissionState, "/mission/state", self.on_state, 10)
        self.create_subscription(Odometry, "/fcu/odometry", self.on_odometry,
                                 qos_profile_sensor_data)
        self.create_subscription(MissionEvent, "/mission/events", self.on_event, 100)
        self.commands = self.create_publisher(MissionCommand, "/mission/command", 10)

    def on_state(self, msg: MissionState) -> None:
        self.states += 1
        print(f"state: {msg.state} (phase {msg.phase}, score {msg.score})", flush=True)
        if self.states == 1:  # the mission is there: send our command
            command = MissionCommand(command=MissionCommand.COMMAND_START,
                                     reason="hello from a user's rclpy node")
            command.header.stamp = self.get_clock().now().to_msg()
            self.commands.publish(command)
            print("sent: START", flush=True)

    def on_odometry(self, msg: Odometry) -> None:
        self.odometry += 1
        if self.odometry % 100 == 1:  # 100 Hz: one line a second
            p = msg.pose.pose.position
            print(f"odometry: ({p.x:.2f}, {p.y:.2f}, {p.z:.2f}) m in {msg.header.frame_id}",
                  flush=True)

    def on_event(self, msg: MissionEvent) -> None:
        if msg.kind in ANSWERS and "START" in msg.message.upper():
            self.answer = ANSWERS[msg.kind]
            print(f"answer: {self.answer}: {msg.message}", flush=True)


def print_graph(node: Node) -> None:
    for name, namespace in sorted(node.get_node_names_and_namespaces()):
        print(f"node: {namespace.rstrip('/')}/{name}")
    for topic, types in sorted(node.get_topic_names_and_types()):
        print(f"topic: {topic} {' '.join(types)}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=3)
    parser.add_argument("--odometry", type=int, default=3)
    parser.add_argument("--timeout", type=float, default=120.0)
    parser.add_argument("--graph", action="store_true",
                        help="print the graph's nodes and topics before exiting")
    args = parser.parse_args()
    rclpy.init()
    node = MissionWatcher()
    deadline = time.monotonic() + args.timeout
    try:
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
            if node.states >= args.states and node.odometry >= args.odometry and node.answer:
                if args.graph:
                    print_graph(node)
                return 0
        print(f"after {args.timeout:g} s: {node.states} states, {node.odometry} odometry, "
              f"answer {node.answer or 'none'}", file=sys.stderr)
        return 1
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
