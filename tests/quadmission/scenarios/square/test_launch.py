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
import signal
import subprocess
import sys
import time
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


@needs_ros2
@pytest.mark.slow
def test_a_killed_pilot_process_respawns_and_the_square_still_lands(tmp_path: Path) -> None:
    # The pilot's process is killed with SIGKILL in the middle of the square. With
    # respawn in the launch file it is started again; the fresh pilot keeps nothing of the
    # dead one: flight control's health (armed, setpoint stream on) tells it the vehicle
    # flies, the odometry where, and it flies on from the nearest corner and lands.
    # Without the respawn nobody would land the vehicle: its death would end the launch.
    # The simulator stops waiting for the dead process in the lockstep, and takes the new
    # one back at its first report.
    launch_file = tmp_path / "square.yaml"
    launch_file.write_text(SQUARE.read_text().replace(
        "    process: pilot\n",
        "    process: pilot\n    respawn: true\n    respawn_delay: 1.0\n"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "quadmission.cli", "launch", str(launch_file), "--transport",
         "ros2", "--domain-id", str(ros_domain("square")), "--duration", "300", "--rtf", "3"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")))
    assert proc.stderr is not None and proc.stdout is not None
    lines: list[str] = []
    pilot_pid = None
    try:
        for line in proc.stderr:
            lines.append(line)
            if line.startswith("launch: started pilot (pid "):
                pilot_pid = int(line.rsplit("pid ", 1)[1].rstrip(")\n"))
            if "square pilot: square" in line and pilot_pid is not None:
                time.sleep(1.0)  # on the first leg, at 3x: about 3 s of simulated flight
                os.kill(pilot_pid, signal.SIGKILL)
                break
        lines += proc.stderr.readlines()  # to the end of the launch
        stdout = proc.stdout.read()
        assert proc.wait(900) == 0, "".join(lines)[-4000:]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    said = "".join(lines)
    assert pilot_pid is not None, said[-3000:]
    assert f"launch: pilot (pid {pilot_pid}) died: killed by SIGKILL; restarting in 1.0 s " \
        "(1 of 3)" in said, said[-3000:]
    assert "launch: restarted pilot (pid " in said
    assert "[simulator] pilot left the lockstep" in said
    assert "[simulator] pilot rejoined the lockstep" in said
    assert "the vehicle is flying; on from corner" in said  # taken over, not taken off again
    assert "[pilot] landed" in said
    reason = json.loads(stdout)["reason"]
    assert reason.startswith("process 'pilot'") and reason.endswith("(finished)"), reason
    assert f"(pid {pilot_pid})" not in reason  # the restarted pilot landed it


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
