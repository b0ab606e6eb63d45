"""A DDS domain of this test session's own, loopback only (parallel runs do not meet)."""

from __future__ import annotations

import os

import pytest

from runtime.dds.config import DdsConfig


@pytest.fixture(scope="session")
def dds_config() -> DdsConfig:
    return DdsConfig(domain_id=100 + os.getpid() % 120)
