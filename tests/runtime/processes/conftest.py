"""Both process transports, each on a loopback-only domain of this test session's own.

``transport_kind`` runs a test once on ``ros2`` (rclpy on Fast DDS; skipped, naming the
command, where the ROS 2 interface packages are not built) and once on ``dds`` (Cyclone).
"""

from __future__ import annotations

import importlib.util
import os

import pytest

from runtime.processes.child import ProcessSpec
from runtime.processes.executor import ProcessTransport

ROS2_BUILT = all(importlib.util.find_spec(m) is not None
                 for m in ("rclpy", "px4_msgs", "quadmission_interfaces"))
needs_ros2 = pytest.mark.skipif(
    not ROS2_BUILT, reason="the ROS 2 wheels or interface packages are missing: "
                           "make ros-interfaces")
TRANSPORT_KINDS = [pytest.param("ros2", marks=needs_ros2), pytest.param("dds")]


@pytest.fixture(scope="session")
def domain_id() -> int:
    return 100 + os.getpid() % 120


@pytest.fixture(params=TRANSPORT_KINDS)
def transport_kind(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def make_transport(kind: str, domain: int, name: str) -> ProcessTransport:
    """A transport as a launch's process makes it (not following /clock)."""
    return ProcessSpec(name, transport=kind, domain_id=domain,
                       use_sim_time=False).make_transport()
