"""``config/launch/mission.yaml`` in process: a mission that cannot start says why.

A full mission is about nine minutes of simulated time, so the checks stop early: in
process, the same file with the visual odometry cut from the start ends with the stop's
reason and a non-zero exit code. Under ROS 2 (each process group in its own process) the
mission is flown through the preflight and the survey takeoff into the exploration by
tests/examples/test_user_node.py, with a user's rclpy program beside it; the full mission
under ROS 2 is run by hand (docs/processes.md).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[4]
MISSION = ROOT / "config" / "launch" / "mission.yaml"


def _variant(tmp_path: Path, parameters: dict[str, dict[str, Any]]) -> Path:
    """mission.yaml with ``parameters[factory]`` added to the node made by ``factory``."""
    doc = yaml.safe_load(MISSION.read_text(encoding="utf-8"))
    for factory, extra in parameters.items():
        (node,) = [n for n in doc["nodes"] if n["factory"] == factory]
        node["parameters"] = dict(node.get("parameters") or {}) | extra
    path = tmp_path / "mission.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def _launch(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "quadmission.cli", "launch", *args],
        cwd=ROOT, capture_output=True, text=True, timeout=900,
        env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")))


def test_mission_launch_in_process_fails_with_the_reason(tmp_path: Path) -> None:
    # No visual odometry at all: the FCU never has a position estimate, so the mission
    # cannot get past its preflight and stops, saying why.
    launch_file = _variant(tmp_path, {
        "flight_control.vio_node:VioNode": {"enabled": False},
        "quadmission.scenarios.mission.launch:mission": {"preflight_timeout_s": 3.0}})
    out = _launch(str(launch_file), "--duration", "60")
    assert out.returncode == 1, out.stderr[-3000:]
    reason = json.loads(out.stdout)["reason"]
    assert reason.startswith("STOPPED: "), reason
    assert "preflight_failed" in reason and "no valid position estimate" in reason, reason
