"""The process transport (``ros2``: rclpy on Fast DDS) on a loopback-only domain of this test
session's own; its tests skip, naming the command, where the ROS 2 build is missing (never
under ``make test``, which builds it: tests/conftest.py).
"""

from __future__ import annotations

import os

import pytest

from runtime.processes.child import ProcessSpec
from runtime.processes.executor import ProcessTransport
from runtime.ros2.config import SETUP_HINT, missing_modules

needs_ros2 = pytest.mark.skipif(
    bool(missing_modules()), reason=f"the ROS 2 wheels or interface packages are missing: "
                                    f"{SETUP_HINT}")
TRANSPORT_KINDS = [pytest.param("ros2", marks=needs_ros2)]


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
