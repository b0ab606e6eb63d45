"""Shared fixtures for the sim tests: headless rendering and the default arena's model."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

from collections.abc import Iterator

import mujoco
import pytest

from sim.arena import ArenaSpec, default_arena
from sim.mjcf import build_model
from sim.render import SceneRenderer
from sim.scene import SceneIndex


@pytest.fixture(scope="session")
def arena() -> ArenaSpec:
    """config/arenas/contest.yaml."""
    return default_arena()


@pytest.fixture(scope="session")
def model(arena: ArenaSpec) -> mujoco.MjModel:
    """The default arena with the default quadrotor, compiled once."""
    return build_model(arena)


@pytest.fixture(scope="session")
def index(model: mujoco.MjModel, arena: ArenaSpec) -> SceneIndex:
    return SceneIndex.from_model(model, arena)


@pytest.fixture
def data(model: mujoco.MjModel) -> mujoco.MjData:
    """Fresh state for each test (the quad on the start pad, robots at t = 0)."""
    state = mujoco.MjData(model)
    mujoco.mj_forward(model, state)
    return state


@pytest.fixture(scope="session")
def renderer(model: mujoco.MjModel) -> Iterator[SceneRenderer]:
    """One set of GL contexts for the session (each costs ~0.5 s with software GL)."""
    with SceneRenderer(model) as scene_renderer:
        yield scene_renderer
