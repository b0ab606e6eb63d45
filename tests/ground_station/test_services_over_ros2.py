"""``--record``, ``--gcs``, ``--foxglove`` under ``quadmission launch --transport ros2``.

The recorder, the page and the Foxglove bridge run as nodes in a process of their own
(``ground_station``) and find the graph's topics as any rcl node does. The launch:
``config/launch/example.yaml`` (the README's talker and listener) on the host's clock,
without a simulator. The page answers, and the operator command posted to it reaches a
subscriber in this test's own process over ROS 2; the Foxglove bridge accepts a
connection; after Ctrl-C the bag holds the talker's ``/chatter``, decoded, with its index
written (the recorder was closed, not killed).
"""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path
from typing import Any

import pytest
from rosbags.highlevel import AnyReader

import interfaces
from ground_station.bag import bag_info
from ground_station.server import TOKEN_ENV
from interfaces.qos import qos_profile_default
from runtime import Node
from runtime.processes.executor import ClockedExecutor
from tests.runtime.processes.conftest import make_transport, needs_ros2, ros_domain

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "config" / "launch" / "example.yaml"
TOKEN = "ros2-launch-token"


class _Stderr:
    """The launch's stderr lines, read in a thread; :meth:`wait_for` a pattern."""

    def __init__(self, stream: Any) -> None:
        self.lines: list[str] = []
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream: Any) -> None:
        for line in stream:
            self.lines.append(line)

    def wait_for(self, pattern: str, timeout_s: float) -> re.Match[str]:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for line in list(self.lines):
                if found := re.search(pattern, line):
                    return found
            time.sleep(0.1)
        raise AssertionError(f"no line matching {pattern!r} after {timeout_s:g} s:\n"
                             + "".join(self.lines[-40:]))


@needs_ros2
@pytest.mark.slow
def test_recorder_and_ground_station_run_as_ros2_nodes(tmp_path: Path) -> None:
    domain = ros_domain("ground_station")
    launch = subprocess.Popen(
        [sys.executable, "-m", "quadmission.cli", "launch", str(EXAMPLE), "--transport",
         "ros2", "--domain-id", str(domain), "--wall-clock", "--record", "--gcs", "--port",
         "0", "--foxglove", "--foxglove-port", "0", "--out", str(tmp_path)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=dict(os.environ, **{TOKEN_ENV: TOKEN}))
    ex = ClockedExecutor(make_transport("ros2", domain, "test_probe"), use_sim_time=False,
                         config_dir=None)
    try:
        stderr = _Stderr(launch.stderr)
        stderr.wait_for(r"started ground_station \(pid \d+\)", 30)
        base = stderr.wait_for(r"ground station: (http://127\.0\.0\.1:\d+/)", 120)[1]
        with urllib.request.urlopen(base + "api/state", timeout=10) as reply:
            assert reply.status == 200 and "mission" in json.load(reply)
        foxglove_port = int(stderr.wait_for(r"Foxglove: open connection ws://127\.0\.0\.1:(\d+)",
                                            30)[1])
        socket.create_connection(("127.0.0.1", foxglove_port), timeout=10).close()

        probe = Node("command_probe", context=ex.context)
        heard: list[Any] = []
        probe.create_subscription("quadmission_interfaces/msg/MissionCommand",
                                  "/mission/command", heard.append, qos_profile_default)
        request = urllib.request.Request(
            base + "api/command", method="POST",
            data=json.dumps({"command": "sequence", "sequence": [2, 1]}).encode(),
            headers={"Authorization": f"Bearer {TOKEN}", "Content-Type": "application/json"})
        deadline = time.monotonic() + 30
        while not heard and time.monotonic() < deadline:  # until the graph has matched us
            with urllib.request.urlopen(request, timeout=10) as reply:
                assert json.load(reply)["ok"]
            until = time.monotonic() + 1.0
            while not heard and time.monotonic() < until:
                ex.spin_once_realtime()
        assert heard, "the page's command never reached /mission/command over ROS 2"
        assert list(heard[0].sequence.pad_ids) == [2, 1]
    finally:
        ex.process_transport.close()
        launch.send_signal(signal.SIGINT)
        try:
            launch.wait(timeout=60)
        except subprocess.TimeoutExpired:
            launch.kill()
            launch.wait()
    assert launch.returncode == 130, "".join(stderr.lines[-40:])

    info = bag_info(tmp_path / "bag")
    assert info.indexed, "the recorder was not closed: its bag has no index"
    with AnyReader([tmp_path / "bag"], default_typestore=interfaces.typestore()) as reader:
        chatter = [reader.deserialize(raw, c.msgtype).data for c, _, raw
                   in reader.messages([c for c in reader.connections if c.topic == "/chatter"])]
    assert chatter and all(text.startswith("hello") for text in chatter), chatter[:5]
