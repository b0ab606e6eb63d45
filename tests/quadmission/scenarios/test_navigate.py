"""`quadmission sim --scenario navigate`: one leg through the whole stack, in the sim.

One flight (module fixture) in the default arena: arm, /navigation/takeoff (climb and
survey turn), one /navigation/navigate from pad 1 to pad 3, which sits behind the long
tall wall at x = 5 m (y 6.5..11.5 m), then land. The planner knows only what the depth
camera mapped; the tests read that one run's report and picture.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from quadmission.scenarios import SCENARIOS, ScenarioOptions
from quadmission.scenarios.navigate import fly_legs

HALF_WIDTH = 0.35  # m, the drone's arms + propellers: less clearance is a touch


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], Path]:
    out = tmp_path_factory.mktemp("navigate")
    options = ScenarioOptions(out=out, seed=0)
    report = fly_legs(options, options.load_arena(), scenario="navigate", pads=[3],
                      limit_s=150.0)
    return report, out


def test_the_leg_reaches_the_pad_behind_the_wall_without_touching_anything(run) -> None:  # type: ignore[no-untyped-def]
    report, out = run
    assert report["scenario"] == "navigate" and "navigate" in SCENARIOS
    assert not report["crashed"], report["verdict"]
    (leg,) = report["legs"]
    assert (leg["from"], leg["to"], leg["reached"]) == (1, 3, True), leg
    assert leg["min_clearance_m"] > HALF_WIDTH
    straight = float(np.hypot(7.0 - 1.5, 10.5 - 1.5))
    assert leg["planned_length_m"] >= straight
    assert leg["flown_length_m"] >= 0.9 * leg["planned_length_m"]
    assert json.loads((out / "report.json").read_text())["legs"] == report["legs"]
    assert (out / "path.png").stat().st_size > 10_000


def test_the_map_came_from_the_depth_camera_and_the_planner_used_it(run) -> None:  # type: ignore[no-untyped-def]
    report, _ = run
    assert report["map_points"] > 1000
    # planned on the growing live map: built once, then updated where it grew
    assert report["graph_builds"] == 1 and report["graph_updates"] > 1, report
    assert all(v is not None and v < 0.3 for v in report["rmse_m"].values()), report["rmse_m"]

