"""Shared fixtures for runtime tests: an executor with no node configs on disk."""

from __future__ import annotations

import pytest

from runtime import DeterministicExecutor


@pytest.fixture
def ex() -> DeterministicExecutor:
    return DeterministicExecutor(config_dir=None, record_trace=True)
