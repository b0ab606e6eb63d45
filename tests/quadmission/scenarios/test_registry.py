"""`quadmission sim`: the square through the real companion stack, and the arena tour.

The square is flown once in the default arena (module fixture) by the SITL flight
controller behind the link, the FCU bridge, the VIO forwarder and the flight-control
node, driven by the mission script; the tests read that one run. A crash and a refusal
use a small boxed-in arena where no square fits.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from quadmission.cli import main
from quadmission.errors import OptionsError, SquareDoesNotFit
from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.square.fit import CLEARANCE, SquarePlan, fit_square, square_blockers
from quadmission.scenarios.square.flight import fly_square
from sim.arena import ArenaSpec, Lighting, arena_from_yaml, default_arena
from sim.arena_generator import generate_arena
from sim.markers import detect_markers
from sim.world import world_params

# Start pad 1 boxed in: tall obstacles 1.2 m east and north of it, the walls 1.5 m west
# and south. No square of 1 m or more keeps 0.6 m clear; a 4 m square hits obstacle_0.
BOXED_IN = """\
name: boxed-in
field: {size: [8.0, 8.0, 4.0]}
start_pad: 1
obstacles:
  - {center: [2.9, 1.5], size: [0.4, 2.0, 3.0]}
  - {center: [1.5, 2.9], size: [2.0, 0.4, 3.0]}
pads:
  - {id: 1, center: [1.5, 1.5]}
robots: []
"""


def _strict_json(path: Path) -> Any:
    """The file parsed as strict JSON: NaN and Infinity are errors."""
    def refuse(constant: str) -> None:
        raise ValueError(f"{path.name} holds {constant}, not strict JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


def _cli(argv: list[str]) -> tuple[int, str]:
    """Exit code and stderr of ``quadmission <argv>``."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    return code, err.getvalue()


@dataclass(frozen=True)
class SquareRun:
    code: int
    stderr: str
    report: dict[str, Any]  # as written to report.json
    out: Path


@pytest.fixture(scope="module")
def square_run(tmp_path_factory: pytest.TempPathFactory) -> SquareRun:
    out = tmp_path_factory.mktemp("square")
    code, stderr = _cli(["sim", "--scenario", "square", "--out", str(out)])
    return SquareRun(code, stderr, _strict_json(out / "report.json"), out)


def test_the_square_lands_through_the_real_stack_within_10_cm(square_run: SquareRun) -> None:
    report = square_run.report
    assert square_run.code == 0, square_run.stderr[-2000:]
    assert report["scenario"] == "square" and report["arena"] == "contest"
    assert report["outcome"] == "landed" and report["landed"] and report["crash"] is None
    rmse = report["tracking"]["rmse_m"]
    assert rmse["xy"] < 0.1, rmse
    assert math.hypot(rmse["x"], rmse["y"]) == pytest.approx(rmse["xy"], abs=1e-3)
    assert report["tracking"]["max_error_m"] >= rmse["xy"]
    # the square is the default 4 m one from the start pad, and the pilot said it landed
    assert report["square"]["side_m"] == 4.0 and report["square"]["start_m"] == [1.5, 1.5]
    assert report["pilot"]["success"] and report["pilot"]["message"].startswith("landed at")
    # judged against the planned outline, every ground-truth sample over the square
    assert report["tracking"]["reference"].startswith("the planned outline")
    window = report["tracking"]["window_s"]
    samples_per_s = world_params().trajectory_rate_hz
    assert report["tracking"]["samples"] > 0.9 * samples_per_s * (window[1] - window[0])
    # commands went to the FCU over the link
    assert report["link"]["to_fcu"]["sent"] > 1000


def test_the_run_prints_progress_and_a_one_line_verdict(square_run: SquareRun) -> None:
    lines = square_run.stderr.splitlines()
    rmse = square_run.report["tracking"]["rmse_m"]["xy"]
    assert lines[-1] == f"landed, RMSE {rmse:.3f} m" == square_run.report["verdict"]
    progress = [line for line in lines if line.lstrip().startswith("t=")]
    assert any("square (corner 4/4)" in line for line in progress)
    times = [float(line.split("=")[1].split()[0]) for line in progress]
    assert times == sorted(times) and times[-1] > 30.0  # simulated seconds, in order


def test_the_report_is_strict_json_with_host_figures_in_their_own_block(
    square_run: SquareRun,
) -> None:
    report = square_run.report
    assert set(report["host"]) == {"wall_time_s", "real_time_factor", "cpu_time_s",
                                   "fcu_overruns"}
    host_keys = {"wall_time_s", "real_time_factor", "rtf", "fcu_overruns"}
    assert not host_keys & set(report), "host-dependent figures outside the host block"
    assert report["flight_time_s"] > 20.0 and report["seed"] == 0


def test_the_run_writes_the_arena_it_flew(square_run: SquareRun) -> None:
    written = arena_from_yaml((square_run.out / "arena.yaml").read_text())
    assert written == default_arena()


def test_the_lighting_option_overrides_the_arenas_preset(tmp_path: Path) -> None:
    options = ScenarioOptions(out=tmp_path, random_arena=True, seed=3, lighting=Lighting.DARK)
    flown = options.load_arena()
    assert flown.lighting is Lighting.DARK
    assert flown == replace(generate_arena(3), lighting=Lighting.DARK)
    assert arena_from_yaml((tmp_path / "arena.yaml").read_text()) == flown


def test_path_png_is_written(square_run: SquareRun) -> None:
    image = cv2.imread(str(square_run.out / square_run.report["path_image"]))
    assert image is not None and image.shape[0] >= 600 and image.shape[1] >= 1000


def test_a_crash_still_writes_the_report_and_the_picture(tmp_path: Path) -> None:
    arena = arena_from_yaml(BOXED_IN)
    forced = SquarePlan((1.5, 1.5), 4.0, 1.5)  # straight through obstacle_0
    report = fly_square(ScenarioOptions(out=tmp_path, seed=3), arena, forced)
    assert report["outcome"] == "crash" and not report["landed"]
    assert report["crash"]["reason"] == "hit obstacle_0"
    crash_x = report["crash"]["position_m"][0]
    assert 2.7 - 0.4 < crash_x < 2.7  # the east obstacle's face, less the drone's reach
    assert report["verdict"] == f"CRASH: hit obstacle_0 at {report['crash']['t_s']:.1f} s"
    assert _strict_json(tmp_path / "report.json") == report
    assert cv2.imread(str(tmp_path / "path.png")) is not None


def test_a_goal_the_flight_control_layer_rejects_ends_the_flight_as_failed(
    tmp_path: Path,
) -> None:
    forced = SquarePlan((1.5, 1.5), 25.0, 1.5)  # the first corner is 6.5 m past the east wall
    report = fly_square(ScenarioOptions(out=tmp_path), default_arena(), forced)
    assert report["outcome"] == "failed" and not report["landed"] and report["crash"] is None
    assert report["verdict"].startswith("FAILED: reach corner 1/4: rejected: ")
    assert report["pilot"]["phase"] == "failed"
    assert report["tracking"]["rmse_m"]["xy"] is None  # no square flown: unknown, not NaN
    assert _strict_json(tmp_path / "report.json") == report
    assert cv2.imread(str(tmp_path / "path.png")) is not None


def test_a_square_that_fits_nowhere_is_refused_with_the_reason(tmp_path: Path) -> None:
    arena_file = tmp_path / "boxed.yaml"
    arena_file.write_text(BOXED_IN)
    code, stderr = _cli(["sim", "--scenario", "square", "--arena", str(arena_file), "--out",
                         str(tmp_path / "o")])
    assert code == 2
    refused = [line for line in stderr.splitlines() if line.startswith("REFUSED: ")]
    assert len(refused) == 1, stderr
    assert "start pad 1" in refused[0] and "obstacle_0" in refused[0]
    report = _strict_json(tmp_path / "o" / "report.json")
    assert report["outcome"] == "refused" and report["verdict"] == refused[0]


def test_arena_and_random_arena_together_is_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["sim", "--arena", "config/arenas/contest.yaml", "--random-arena",
              "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err
    with pytest.raises(OptionsError, match="not both"):
        ScenarioOptions(out=tmp_path, arena=Path("x.yaml"), random_arena=True)


# -- the fit, alone ---------------------------------------------------------------------------

def _clear_of_tall_obstacles_and_walls(arena: ArenaSpec, plan: SquarePlan) -> float:
    """Smallest distance [m] from points along the square's edges (every 5 cm) to a wall
    or an obstacle taller than the flight, measured here independently of the fit."""
    outline = np.array(plan.outline())
    sx, sy = arena.field.size[0], arena.field.size[1]
    nearest = math.inf
    for a, b in itertools.pairwise(outline):
        for u in np.linspace(0.0, 1.0, int(plan.side / 0.05) + 1):
            x, y = a + u * (b - a)
            nearest = min(nearest, x, y, sx - x, sy - y)
            for box in arena.obstacles:
                if box.height > plan.altitude - 0.3:
                    r = box.footprint
                    dx = max(r.xmin - x, 0.0, x - r.xmax)
                    dy = max(r.ymin - y, 0.0, y - r.ymax)
                    nearest = min(nearest, math.hypot(dx, dy))
    return nearest


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_the_square_fitted_to_a_random_arena_starts_on_the_start_pad_and_keeps_clear(
    seed: int,
) -> None:
    arena = generate_arena(seed)
    plan = fit_square(arena)
    assert plan.start == arena.pad(arena.start_pad).center
    assert 1.0 <= plan.side <= 4.0
    assert _clear_of_tall_obstacles_and_walls(arena, plan) >= CLEARANCE - 1e-9


def test_the_fit_shrinks_the_square_for_a_tall_obstacle_but_not_for_a_low_one() -> None:
    arena = default_arena()
    assert fit_square(arena).side == 4.0
    text = BOXED_IN.replace("obstacles:\n  - {center: [2.9, 1.5], size: [0.4, 2.0, 3.0]}\n"
                            "  - {center: [1.5, 2.9], size: [2.0, 0.4, 3.0]}",
                            "obstacles:\n  - {center: [5.5, 3.5], size: [0.4, 0.4, HEIGHT]}")
    low = fit_square(arena_from_yaml(text.replace("HEIGHT", "0.8")))
    tall = arena_from_yaml(text.replace("HEIGHT", "3.0"))
    assert low.side == 4.0 and low.direction == (1, 1)
    fitted = fit_square(tall)
    # its west face is at x = 5.3: the east edge 1.5 + side must stay 0.6 m short of it,
    # so side <= 3.2, and the sides tried go down by 0.25 m; the other ways hit the walls
    assert fitted.side == 3.0 and fitted.direction == (1, 1)
    assert _clear_of_tall_obstacles_and_walls(tall, fitted) >= CLEARANCE - 1e-9


def test_robots_block_the_square_only_when_it_flies_as_low_as_they_are_tall() -> None:
    # robot 14 drives (1.5, 3.5) -> (3.5, 3.5) -> (3.5, 5.0), across the default square
    arena = default_arena()
    square_4m = SquarePlan((1.5, 1.5), 4.0, 1.5)
    assert square_blockers(arena, square_4m) == []
    low = square_blockers(arena, SquarePlan((1.5, 1.5), 4.0, 0.5))
    assert "robot_14" in [b.name for b in low]
    assert fit_square(arena, altitude=0.5).side < 4.0


def test_the_fit_refuses_a_boxed_in_start_pad() -> None:
    with pytest.raises(SquareDoesNotFit, match=r"toward \+x\+y obstacle_0"):
        fit_square(arena_from_yaml(BOXED_IN))


def test_a_random_arena_square_lands(tmp_path: Path) -> None:
    code, stderr = _cli(["sim", "--scenario", "square", "--random-arena", "--seed", "2",
                         "--out", str(tmp_path)])
    report = _strict_json(tmp_path / "report.json")
    assert code == 0 and report["outcome"] == "landed", stderr[-2000:]
    assert report["seed"] == 2 and report["random_arena"]
    assert report["square"]["start_m"] == list(generate_arena(2).pad(
        generate_arena(2).start_pad).center)
    assert report["tracking"]["rmse_m"]["xy"] < 0.1


# -- the arena tour ---------------------------------------------------------------------------

def test_arena_tour_writes_pictures_and_decodes_every_pad(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tour"
    assert main(["sim", "--scenario", "arena-tour", "--out", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["pads_total"] == 10 and report["all_decoded"]
    assert [p["id"] for p in report["pads"]] == list(range(1, 11))
    arena = cv2.imread(str(out / "arena.png"))
    assert arena is not None and arena.shape[1] == 1000
    for pad in report["pads"]:
        # the saved picture really shows that pad's marker, decoded again here
        frame = cv2.cvtColor(cv2.imread(str(out / pad["image"])), cv2.COLOR_BGR2RGB)
        assert frame.shape == (480, 640, 3)
        assert sorted(detect_markers(frame)) == [pad["id"]]
    err = capsys.readouterr().err
    assert "pad 10" in err  # progress is shown
    assert err.splitlines()[-1] == "decoded 10/10 pads"


def test_a_random_arena_tour_also_decodes(tmp_path: Path) -> None:
    assert main(["sim", "--scenario", "arena-tour", "--random-arena", "--seed", "7",
                 "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["all_decoded"] and report["seed"] == 7


def test_a_bad_arena_file_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nfield: {size: [20, 14, 4]}\npads: []\nbogus: 1\n")
    assert main(["sim", "--arena", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml" in err and "bogus" in err
