"""Our endpoints as tools that are not ours see them, from another process, on loopback.

The talker (:mod:`tests.runtime.dds.talker_process`) runs our node API on the DDS
transport. Then: ``cyclonedds ls`` lists its ``rt/``, ``rq/``, ``rr/`` topics with the
ROS 2 type names; ``cyclonedds subscribe`` decodes its messages (from the type
information our endpoints announce); and a plain cyclonedds program built from the IDL
alone (:mod:`tests.runtime.dds.plain_subscriber`) reads them and calls the service.
Everything uses the generated loopback-only configuration on this session's domain.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from runtime.dds.config import DdsConfig

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
CLI = Path(sys.executable).parent / "cyclonedds"


@pytest.fixture(scope="module")
def env(dds_config: DdsConfig) -> dict[str, str]:
    return dict(os.environ, CYCLONEDDS_URI=dds_config.xml(), PYTHONPATH=str(ROOT),
                COLUMNS="200", NO_COLOR="1")


@pytest.fixture(scope="module")
def talker(dds_config: DdsConfig, env: dict[str, str]) -> Iterator[subprocess.Popen[str]]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "tests.runtime.dds.talker_process", str(dds_config.domain_id)],
        env=env, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    try:
        assert proc.stdout.readline().strip() == "ready"
        yield proc
        proc.terminate()
        assert proc.wait(10) == 0, "the talker did not stop cleanly on SIGTERM"
    finally:  # a talker that failed to start or to stop is not left running
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()


def _cli(env: dict[str, str], *args: str) -> str:
    out = subprocess.run([str(CLI), *args, "--suppress-progress-bar"], env=env,
                         capture_output=True, text=True, timeout=60)
    return out.stdout + out.stderr


def test_cyclonedds_ls_shows_ros2_names(talker: object, dds_config: DdsConfig,
                                        env: dict[str, str]) -> None:
    text = _cli(env, "ls", "-i", str(dds_config.domain_id), "-r", "3s")
    for expected in ("rt/foreign/chatter", "std_msgs::msg::dds_::String_",
                     "rq/foreign/armRequest", "rr/foreign/armReply",
                     "quadmission_interfaces::srv::dds_::Arm_Request_"):
        assert expected in text, f"{expected} missing from `cyclonedds ls`:\n{text}"


def test_cyclonedds_subscribe_decodes_our_messages(talker: object, dds_config: DdsConfig,
                                                   env: dict[str, str]) -> None:
    # it subscribes until Ctrl-C: read until a decoded sample shows, then stop it
    proc = subprocess.Popen([str(CLI), "subscribe", "rt/foreign/chatter", "-i",
                             str(dds_config.domain_id), "-r", "2s", "--suppress-progress-bar"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    seen: list[str] = []
    try:
        for line in proc.stdout:
            seen.append(line)
            if "String_(data='hello " in line or len(seen) > 50:
                break
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
    assert any("String_(data='hello " in line for line in seen), "".join(seen)


def test_plain_cyclonedds_client_from_idl(talker: object, dds_config: DdsConfig,
                                          env: dict[str, str]) -> None:
    out = subprocess.run([sys.executable, str(HERE / "plain_subscriber.py"),
                          str(dds_config.domain_id)], env=env, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
    lines = out.stdout.splitlines()
    assert sum(line.startswith("String: hello ") for line in lines) >= 3
    assert "reply: success=True message=armed with timeout 2.5" in lines
