"""Test-wide set-up: headless rendering must be chosen before anything imports mujoco."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from hypothesis import settings

# Property tests draw the same examples on every run, so a CI failure replays locally.
settings.register_profile("deterministic", derandomize=True, deadline=None)
settings.load_profile("deterministic")
