"""Same seed, same mission: two runs of the mission's first 25 s through every node (the
take-off with its survey, mapping, the scanner on noisy frames, the start of the
exploration) give the same report but for the ``host`` block: the same states at the same
times, the same distance flown and tracking errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.mission.scenario import fly_mission

pytestmark = pytest.mark.slow

LIMIT_S = 25.0  # s of simulated time: past the take-off (~22 s), into the exploration


def _run(out: Path, seed: int) -> dict:
    report = fly_mission(ScenarioOptions(out=out, seed=seed), limit_s=LIMIT_S)
    del report["host"]
    return report


def test_same_seed_same_report(tmp_path: Path) -> None:
    first = _run(tmp_path / "a", seed=4)
    second = _run(tmp_path / "b", seed=4)
    assert [s["state"] for s in first["states"]][:4] == [
        "idle", "preflight", "mission.takeoff", "mission.explore"]
    assert first["distance_m"] > 2.0  # it flew: the climb, the survey turn, some exploring
    assert json.dumps(first, sort_keys=True) == json.dumps(second, sort_keys=True)
