"""``config/launch/square.yaml`` flies the square in one process and as ROS 2 processes.

The same YAML and the same node code: in process, the simulator steps every node in
lockstep; under ROS 2 (``--transport ros2``), the simulator, the bridge, the flight-control
node and the pilot are four processes of rcl nodes on a loopback-only domain of their own,
following ``/clock`` paced to three times real time, in lockstep with them (the simulator
waits for a lagging process), beside a process that burns a core. Both end with exit code 0
once the pilot has landed. (Beside two such processes, one per core, it lands too, at a
lower real-time factor: benchmarks/bench_ros2.py, ``square_beside_busy_loops``.)
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader

import interfaces
from quadmission.scenarios.square.launch import sitl
from runtime import DeterministicExecutor
from tests.runtime.processes.conftest import needs_ros2, ros_domain

ROOT = Path(__file__).resolve().parents[4]
SQUARE = ROOT / "config" / "launch" / "square.yaml"


def test_square_launch_lands_in_process_and_records_its_topics(tmp_path: Path) -> None:
    out = subprocess.run(
        [sys.executable, "-m", "quadmission.cli", "launch", str(SQUARE), "--duration", "240",
         "--record", "--out", str(tmp_path)],
        cwd=ROOT, capture_output=True, text=True, timeout=900,
        env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")))
    assert out.returncode == 0, out.stderr[-3000:]
    assert json.loads(out.stdout)["reason"] == "landed"
    with AnyReader([tmp_path / "bag"], default_typestore=interfaces.typestore()) as reader:
        topics = {c.topic for c in reader.connections}
        stamps = [t for _, t, _ in reader.messages(
            [c for c in reader.connections if c.topic == "/fcu/status"])]
    assert {"/fcu/status", "/fcu/setpoint", "/fcu/odometry", "/fcu/imu"} <= topics
    # the FCU's raw uXRCE-DDS side and /clock are left out (config/bag_recorder.yaml): the
    # bridge's /fcu/* topics carry the same data, the bag's timestamps are the clock
    assert not {t for t in topics if t.startswith(("/fmu/", "/xrce_session/"))}
    assert "/clock" not in topics
    assert (stamps[-1] - stamps[0]) / 1e9 > 20.0  # the whole flight, not its start


@needs_ros2
@pytest.mark.slow
def test_square_launch_lands_over_ros2_processes_at_3x_on_a_starved_cpu() -> None:
    # Three times real time, with a process burning a core beside the launch: the node
    # processes are descheduled for milliseconds at a time. The simulator keeps in
    # lockstep with them (never more than a few ms of simulated time ahead), so the
    # bridge's time sync and the FCU's vision stay valid; when it could run 0.25 s ahead,
    # this ended in "no valid position estimate" before the takeoff (issue 10).
    domain = ros_domain("square")
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"])]
    try:
        out = subprocess.run(
            [sys.executable, "-m", "quadmission.cli", "launch", str(SQUARE), "--transport",
             "ros2", "--domain-id", str(domain), "--duration", "240", "--rtf", "3"],
            cwd=ROOT, capture_output=True, text=True, timeout=900,
            env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")))
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    assert out.returncode == 0, out.stderr[-3000:]
    assert json.loads(out.stdout)["reason"].startswith("process 'pilot'")
    assert "[pilot] landed" in out.stderr
    for process in ("simulator", "bridge", "flight_control", "pilot"):
        assert f"started {process} (pid" in out.stderr


def test_a_crash_fails_the_launch_with_its_reason() -> None:
    # Dropped from 4 m with the motors off: a hard touchdown, reported as the launch's
    # failure (the simulator process prints it and exits with this code under ros2).
    simulation = sitl(DeterministicExecutor())
    simulation.sitl.scene.place_at_takeoff(height=4.0)
    ticks: list[int] = []
    result = simulation.run(5.0, stop=lambda: False, tick=ticks.append)
    assert result.exit_code == 1
    assert result.reason.startswith("CRASH: ") and "touchdown" in result.reason, result.reason
    steps = np.diff(ticks)
    assert len(steps) and steps.max() - steps.min() <= 1  # [ns] a steady tick
    assert steps.max() <= 1_400_000  # /clock about every millisecond
