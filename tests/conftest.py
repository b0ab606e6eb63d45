"""Test-wide set-up: headless rendering must be chosen before anything imports mujoco; under
``make test`` (``QUADMISSION_REQUIRE_ROS2=1``) a missing ROS 2 build stops the run instead of
letting the ROS 2 tests skip."""

from __future__ import annotations

import os
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

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
