"""``examples/user_node.py``, a plain rclpy program, joins a mission flown on ROS 2.

The mission (``config/launch/mission.yaml --transport ros2``: the simulator and the four
node groups each in its own process, through the preflight and the takeoff, stopped once
it enters the exploration) and the user's script run side by side, each in its own processes: the
script sees ``/mission/state`` and ``/fcu/odometry`` decoded by rclpy's own classes, the
mission answers the command it sends on ``/mission/command``, and rclpy's graph API lists
every node of the mission by name and its ``/fmu``, ``/fcu``, ``/perception`` and
``/mission`` topics with their ROS 2 types.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from interfaces.px4.topics import FMU_IN, FMU_OUT
from tests.quadmission.scenarios.mission.test_launch import _variant
from tests.runtime.processes.conftest import needs_ros2, ros_domain

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "examples" / "user_node.py"

#: every node of mission.yaml: the simulator's, then each process group's
MISSION_NODES = {"/fcu_agent", "/sim_sensors", "/sim_vision",
                 "/fcu_bridge", "/vio", "/flight_control",
                 "/aruco_scanner", "/precision_land",
                 "/mapping", "/path_finder", "/navigator",
                 "/mission", "/operator"}
_OURS = "quadmission_interfaces/msg/"
#: the contract's topics (docs: DESIGN's table) with their ROS 2 types
CONTRACT_TOPICS = {t.name: t.type for t in (*FMU_OUT.values(), *FMU_IN.values())} | {
    "/fcu/odometry": "nav_msgs/msg/Odometry",
    "/fcu/imu": "sensor_msgs/msg/Imu",
    "/fcu/battery": "sensor_msgs/msg/BatteryState",
    "/fcu/status": _OURS + "FcuStatus",
    "/perception/markers": _OURS + "MarkerDetectionArray",
    "/perception/robot_found": _OURS + "RobotFound",
    "/mission/state": _OURS + "MissionState",
    "/mission/events": _OURS + "MissionEvent",
    "/mission/command": _OURS + "MissionCommand",
}


@needs_ros2
@pytest.mark.slow
def test_user_rclpy_node_sees_the_mission_and_gets_an_answer(tmp_path: Path) -> None:
    launch_file = _variant(tmp_path, {"quadmission.scenarios.mission.launch:mission": {
        "until_state": "mission.explore"}})
    domain = ros_domain("user_node")
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    launch = subprocess.Popen(
        [sys.executable, "-m", "quadmission.cli", "launch", str(launch_file), "--transport",
         "ros2", "--domain-id", str(domain), "--duration", "120"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        # the script only: no PYTHONPATH to our code, the environment a ROS 2 user has
        user_env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        from runtime.ros2.config import Ros2Config  # imports rclpy: only once it is built

        user_env |= Ros2Config(domain).environment()
        user = subprocess.run([sys.executable, str(SCRIPT), "--timeout", "600", "--graph"],
                              cwd=tmp_path, capture_output=True, text=True, env=user_env,
                              timeout=700)
        out, err = launch.communicate(timeout=900)
    finally:
        if launch.poll() is None:
            launch.kill()
            launch.wait()
    assert user.returncode == 0, user.stdout[-2000:] + user.stderr[-2000:]
    lines = user.stdout.splitlines()
    assert any(s.startswith("state: ") for s in lines), lines
    assert any(s.startswith("odometry: ") and s.endswith(" m in map") for s in lines), lines
    assert "sent: START" in lines
    answer = next(s for s in lines if s.startswith("answer: "))
    assert "START" in answer and ("accepted" in answer or "rejected" in answer), answer
    assert launch.returncode == 0, err[-3000:]
    assert json.loads(out)["reason"].startswith("process 'mission'"), out
    # through the preflight (every module healthy, every action server answering) and the
    # survey takeoff, each process group in its own process
    assert "[mission] reached mission.explore\n" in err, err[-3000:]
    for process in ("simulator", "companion", "perception", "navigation", "mission"):
        assert f"started {process} (pid" in err

    nodes = {s.removeprefix("node: ") for s in lines if s.startswith("node: ")}
    assert nodes >= MISSION_NODES, f"not in the graph: {sorted(MISSION_NODES - nodes)}"
    topics = dict(s.removeprefix("topic: ").split(" ", 1) for s in lines
                  if s.startswith("topic: "))
    wrong = {name: (want, topics.get(name, "absent")) for name, want in CONTRACT_TOPICS.items()
             if topics.get(name) != want}
    assert not wrong, f"topic: (type wanted, type in the graph): {wrong}"
    # and nothing under those prefixes without a ROS 2 type of the built packages
    ours = {n: t for n, t in topics.items()
            if n.split("/")[1] in ("fmu", "fcu", "perception", "mission")}
    untyped = {n: t for n, t in ours.items()
               if " " in t or t.split("/")[0] not in ("px4_msgs", "quadmission_interfaces",
                                                      "nav_msgs", "sensor_msgs",
                                                      "geometry_msgs", "std_msgs")}
    assert not untyped, untyped
