"""Test-wide set-up: headless rendering must be chosen before anything imports mujoco; under
``make test`` (``QUADMISSION_REQUIRE_ROS2=1``) a missing ROS 2 build stops the run instead of
letting the ROS 2 tests skip; every test sees ROS 2's environment fresh (loopback-only
discovery, its own ROS_HOME and log folder) and leaves it as it found it."""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

import pytest
from hypothesis import settings

# Property tests draw the same examples on every run, so a CI failure replays locally.
settings.register_profile("deterministic", derandomize=True, deadline=None)
settings.load_profile("deterministic")


def pytest_sessionstart(session: object) -> None:
    from runtime.ros2.config import SETUP_HINT, missing_modules

    missing = missing_modules()
    if os.environ.get("QUADMISSION_REQUIRE_ROS2") == "1" and missing:
        import pytest

        pytest.exit(f"QUADMISSION_REQUIRE_ROS2=1 but {', '.join(missing)} cannot be imported: "
                    f"the ROS 2 tests would skip; {SETUP_HINT}", returncode=4)


def pytest_collection_modifyitems(items: list[Any]) -> None:
    """Tests marked slow first, the rest in their order (a stable sort): a parallel run
    (``make test`` runs pytest-xdist) then ends on short tests on every worker instead of
    waiting for one long flight."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


#: what rcl, rmw and Fast DDS read from the environment: a process transport writes some of
#: them into the test process (runtime.ros2.config.Ros2Config.apply), and every child a
#: test starts inherits them, so each test starts from the same ones and restores them
ROS_ENVIRONMENT = ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOCALHOST_ONLY",
                   "ROS_STATIC_PEERS", "RMW_IMPLEMENTATION", "FASTRTPS_DEFAULT_PROFILES_FILE",
                   "FASTDDS_DEFAULT_PROFILES_FILE", "ROS_HOME", "ROS_LOG_DIR")


@pytest.fixture(autouse=True)
def ros_environment(monkeypatch: pytest.MonkeyPatch,
                    tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """No ROS 2 variable of the shell or of an earlier test: discovery stays on this
    machine, rcl's logs go to a folder of this test's own (not the shared ~/.ros/log),
    our Fast DDS profile applies; a process test names its domain itself
    (tests/runtime/processes/conftest.py: ros_domain). On teardown monkeypatch puts back
    every one of these, including what the test's transports wrote."""
    for name in ROS_ENVIRONMENT:
        monkeypatch.delenv(name, raising=False)
    home = tmp_path_factory.mktemp("ros_home")
    monkeypatch.setenv("ROS_HOME", str(home))
    monkeypatch.setenv("ROS_LOG_DIR", str(home / "log"))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    yield
