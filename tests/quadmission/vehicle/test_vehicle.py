"""``quadmission vehicle``: the simulator alone, on the wall clock, as PX4 v1.17 behind its
uXRCE-DDS agent, the cameras and a VIO stand on the ROS 2 graph.

Each test starts the vehicle as a process, on a ROS domain of its own
(tests/runtime/processes/conftest.py), and looks at it from outside: the graph as rclpy
sees it, the files it writes when it is stopped, and a companion bridge's time sync
across a restart of the vehicle. No wall-clock time is asserted.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from interfaces import graph
from interfaces.px4.topics import FMU_IN, FMU_OUT
from quadmission.vehicle.truth import TRUTH_NPZ, VEHICLE_JSON, load_truth
from tests.runtime.processes.conftest import make_transport, needs_ros2, ros_domain

ROOT = Path(__file__).resolve().parents[3]
UP = "vehicle up on ROS domain"
#: generous: the machine may be busy (a campaign on both cores)
_UP_S = 300.0
_GRAPH_S = 120.0

#: what the vehicle publishes: the agent's /fmu/out, the cameras, the VIO; nothing else
PUBLISHED = {t.name: ("/fcu_agent", t.type) for t in FMU_OUT.values()} | {
    t.name: ("/sim_sensors", t.type) for t in (graph.CAMERA_DOWN_RAW, graph.CAMERA_DOWN_INFO,
                                               graph.CAMERA_DEPTH_POINTS)} | {
    graph.SIM_VISION_POSE.name: ("/sim_vision", graph.SIM_VISION_POSE.type)}
SUBSCRIBED = {t.name: ("/fcu_agent", t.type) for t in FMU_IN.values()}
_ROS_OWN = {"/rosout", "/parameter_events"}  # every rcl node's


def _env() -> dict[str, str]:
    return dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"),
                PYTHONPATH=os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH"))
                                           if p))


def start_vehicle(out: Path, domain: int, *args: str) -> tuple[subprocess.Popen[str], Path]:
    """``quadmission vehicle`` on ``domain``, its output in ``out``; waits until it is up."""
    out.mkdir(parents=True, exist_ok=True)
    log = out.parent / f"{out.name}.log"
    with log.open("w") as f:
        proc = subprocess.Popen(
            [sys.executable, "-m", "quadmission.cli", "vehicle", "--out", str(out),
             "--domain-id", str(domain), *args],
            cwd=ROOT, stdout=f, stderr=subprocess.STDOUT, text=True, env=_env())
    wait_for(log, UP, proc, _UP_S)
    return proc, log


def wait_for(log: Path, text: str, proc: subprocess.Popen[str] | None, timeout_s: float,
             count: int = 1) -> str:
    deadline = time.monotonic() + timeout_s
    while True:
        content = log.read_text(errors="replace")
        if content.count(text) >= count:
            return content
        if proc is not None and proc.poll() is not None:
            raise AssertionError(f"ended (code {proc.returncode}) before {text!r}:\n"
                                 f"{content[-3000:]}")
        if time.monotonic() > deadline:
            raise AssertionError(f"no {text!r} after {timeout_s:g} s:\n{content[-3000:]}")
        time.sleep(0.2)


def stop(proc: subprocess.Popen[str], sig: int = signal.SIGINT) -> int:
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(60)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


@pytest.fixture
def domain() -> int:
    return ros_domain("vehicle")


@pytest.fixture
def vehicle(tmp_path: Path, domain: int) -> Iterator[tuple[subprocess.Popen[str], Path, Path]]:
    out = tmp_path / "vehicle"
    proc, log = start_vehicle(out, domain)
    try:
        yield proc, out, log
    finally:
        stop(proc)


@needs_ros2
@pytest.mark.slow
def test_it_publishes_and_subscribes_what_px4_its_agent_the_cameras_and_a_vio_do(
        vehicle: tuple[subprocess.Popen[str], Path, Path], domain: int) -> None:
    proc, _out, log = vehicle
    transport = make_transport("ros2", domain, "graph_probe")
    try:
        node = transport.rcl_node()

        def endpoints() -> tuple[dict[str, tuple[str, str]], dict[str, tuple[str, str]], dict]:
            pubs, subs, qos = {}, {}, {}
            for name, _types in node.get_topic_names_and_types():
                if name in _ROS_OWN:
                    continue
                for info in node.get_publishers_info_by_topic(name):
                    pubs[name] = ("/" + info.node_name, info.topic_type)
                    qos[name] = info.qos_profile
                for info in node.get_subscriptions_info_by_topic(name):
                    if info.node_name != "_process_graph_probe":
                        subs[name] = ("/" + info.node_name, info.topic_type)
            return pubs, subs, qos

        deadline = time.monotonic() + _GRAPH_S
        while True:  # discovery takes a moment, more on a busy machine
            pubs, subs, qos = endpoints()
            if (pubs, subs) == (PUBLISHED, SUBSCRIBED) or time.monotonic() > deadline:
                break
            transport.wait(0.5)
            transport.dispatch()
    finally:
        transport.close()
    assert pubs == PUBLISHED, f"published: {sorted(set(pubs) ^ set(PUBLISHED))} differ"
    assert subs == SUBSCRIBED, f"subscribed: {sorted(set(subs) ^ set(SUBSCRIBED))} differ"
    assert graph.CLOCK.name not in pubs  # no lockstep, no /clock
    for topic in FMU_OUT.values():  # the agent's QoS: PX4's uXRCE-DDS client's
        got = qos[topic.name]
        assert (got.reliability.name, got.durability.name) == (
            topic.qos.reliability.name, topic.qos.durability.name), topic.name
    assert proc.poll() is None, log.read_text()[-2000:]


@needs_ros2
@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_ends_it_cleanly_writing_its_ground_truth(tmp_path: Path, domain: int,
                                                           sig: int) -> None:
    out = tmp_path / "vehicle"
    proc, log = start_vehicle(out, domain, "--seed", "3", "--lighting", "dark")
    wait_for(log, "FCU nav_state", proc, _UP_S)
    time.sleep(2.0)  # a little flight time on the pad
    assert stop(proc, sig) == 0, log.read_text()[-3000:]
    text = log.read_text()
    assert f"stopped by {signal.Signals(sig).name}" in text, text[-2000:]
    summary = json.loads((out / VEHICLE_JSON).read_text())
    assert summary["seed"] == 3 and summary["lighting"] == "dark" and summary["crash"] is None
    assert summary["sim_time_s"] > 0 and summary["behind"]["episodes"] >= 0
    assert "host_ns_at_sim_zero" in summary and (out / "arena.yaml").is_file()
    truth = load_truth(out)
    assert len(truth.trajectory) > 0 and (out / TRUTH_NPZ).is_file()
    assert truth.trajectory.t[-1] <= summary["sim_time_s"] + 1e-6
    # on its pad, at rest: the truth says where it stands
    assert np.allclose(truth.trajectory.position[-1, :2], [1.5, 1.5], atol=0.05)


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "quadmission.cli", *args], cwd=ROOT,
                          capture_output=True, text=True, env=_env(), timeout=300)


@pytest.mark.parametrize(("args", "said"), [
    (["--fault", "node_stop@5,name=navigation"], "not a fault of the vehicle"),
    (["--fault", "bogus@1"], "bogus"),
    (["--domain-id", "400"], "outside 0..232"),
])
def test_bad_input_is_said_in_one_line(tmp_path: Path, args: list[str], said: str) -> None:
    done = _cli("vehicle", "--out", str(tmp_path / "v"), *args)
    assert done.returncode == 2, done.stderr
    assert said in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_a_rate_that_is_not_positive_is_refused(tmp_path: Path) -> None:
    done = _cli("vehicle", "--out", str(tmp_path / "v"), "--rtf", "0")
    assert done.returncode == 2 and "--rtf" in done.stderr, done.stderr


BRIDGE_ONLY = """\
nodes:
  - factory: flight_control.bridge_node:FcuBridgeNode
    process: companion
    parameters:
      timesync_source: fcu_status
      timesync_estimator: px4
"""


@needs_ros2
@pytest.mark.slow
def test_a_vehicle_that_restarts_makes_the_bridge_sync_its_time_again(
        tmp_path: Path, domain: int) -> None:
    """companion.yaml's bridge (time sync from /fmu/out/timesync_status, PX4's filter)
    against the vehicle's own boot clock: converged; the vehicle stops and comes back (a
    new boot, seconds later on the host's clock): the offset steps, the filter restarts
    and converges again."""
    launch_file = tmp_path / "bridge.yaml"
    launch_file.write_text(BRIDGE_ONLY)
    first, _ = start_vehicle(tmp_path / "first", domain)
    bridge_log = tmp_path / "bridge.log"
    with bridge_log.open("w") as f:
        bridge = subprocess.Popen(
            [sys.executable, "-m", "quadmission.cli", "launch", str(launch_file),
             "--transport", "ros2", "--wall-clock", "--domain-id", str(domain)],
            cwd=ROOT, stdout=f, stderr=subprocess.STDOUT, text=True, env=_env())
    second = None
    try:
        wait_for(bridge_log, "time sync converged", bridge, _UP_S)
        assert stop(first, signal.SIGTERM) == 0
        second, _ = start_vehicle(tmp_path / "second", domain)
        text = wait_for(bridge_log, "time sync converged", bridge, _UP_S, count=2)
    finally:
        for proc in (bridge, first, second):
            if proc is not None:
                stop(proc)
    restarted = [line for line in text.splitlines() if "time sync restarted" in line]
    assert restarted, text[-3000:]
    assert "the clock offset stepped from" in restarted[0]
