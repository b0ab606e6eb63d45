"""Same seed, same mission: two runs of the mission's first 25 s through every node (the
take-off with its survey, mapping, the scanner on noisy frames, the start of the
exploration) give the same report but for the ``host`` block: the same states at the same
times, the same distance flown and tracking errors. And a third without threads (the
cameras drawn and the scans made in line) gives it too."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.mission.scenario import fly_mission
from runtime.executor import THREADS_VARIABLE

pytestmark = pytest.mark.slow

LIMIT_S = 25.0  # s of simulated time: past the take-off (~22 s), into the exploration


def _run(out: Path, seed: int) -> dict:
    report = fly_mission(ScenarioOptions(out=out, seed=seed), limit_s=LIMIT_S)
    del report["host"]
    return report


def test_same_seed_same_report_with_threads_or_without(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    first = _run(tmp_path / "a", seed=4)
    monkeypatch.setenv(THREADS_VARIABLE, "0")
    in_line = _run(tmp_path / "c", seed=4)
    monkeypatch.delenv(THREADS_VARIABLE)
    second = _run(tmp_path / "b", seed=4)
    assert [s["state"] for s in first["states"]][:4] == [
        "idle", "preflight", "mission.takeoff", "mission.explore"]
    assert first["distance_m"] > 2.0  # it flew: the climb, the survey turn, some exploring
    assert json.dumps(first, sort_keys=True) == json.dumps(second, sort_keys=True)
    assert json.dumps(first, sort_keys=True) == json.dumps(in_line, sort_keys=True)
