"""Test-wide set-up: headless rendering must be chosen before anything imports mujoco."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")
