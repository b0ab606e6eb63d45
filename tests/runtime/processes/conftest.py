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


#: the tests that start ROS 2 processes, each on a domain of its own (ros_domain)
_DOMAIN_USERS = ("runtime", "square", "ground_station", "user_node")
_FIRST_DOMAIN, _DOMAINS = 100, 130  # 100..229 (ROS 2 domain ids end at 232)


def ros_domain(user: str) -> int:
    """A loopback domain for ``user`` (one of :data:`_DOMAIN_USERS`), this test process's
    own: pytest-xdist's workers of one run get disjoint blocks, separate runs most likely
    do too (by their run id or pid), so parallel tests never hear each other."""
    blocks = _DOMAINS // len(_DOMAIN_USERS)
    worker, run = os.environ.get("PYTEST_XDIST_WORKER"), os.environ.get("PYTEST_XDIST_TESTRUNUID")
    if worker and run:
        block = (int(run, 16) + int(worker.removeprefix("gw"))) % blocks
    else:
        block = os.getpid() % blocks
    return _FIRST_DOMAIN + block * len(_DOMAIN_USERS) + _DOMAIN_USERS.index(user)


@pytest.fixture(scope="session")
def domain_id() -> int:
    return ros_domain("runtime")


@pytest.fixture(params=TRANSPORT_KINDS)
def transport_kind(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def make_transport(kind: str, domain: int, name: str) -> ProcessTransport:
    """A transport as a launch's process makes it (not following /clock)."""
    return ProcessSpec(name, transport=kind, domain_id=domain,
                       use_sim_time=False).make_transport()
