"""docs/results.md and the README's headline table are what tools/results_page.py makes of
benchmarks/results/*.json now: a benchmark re-run without `make docs` fails here."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TOOL = ROOT / "tools" / "results_page.py"
RESULTS = ROOT / "benchmarks" / "results"


def run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(TOOL), *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=120, check=False)


def copy_of_the_inputs(tmp_path: Path) -> tuple[Path, Path, Path]:
    results = tmp_path / "results"
    shutil.copytree(RESULTS, results)
    page, readme = tmp_path / "results.md", tmp_path / "README.md"
    shutil.copy(ROOT / "docs" / "results.md", page)
    shutil.copy(ROOT / "README.md", readme)
    return results, page, readme


def test_the_committed_pages_are_what_the_json_gives_now() -> None:
    done = run("--check")
    assert done.returncode == 0, f"stale: run `make docs`\n{done.stderr}"


def test_a_new_benchmark_result_makes_the_pages_stale_until_regenerated(tmp_path: Path) -> None:
    results, page, readme = copy_of_the_inputs(tmp_path)
    mission = json.loads((results / "mission.json").read_text(encoding="utf-8"))
    runs = mission["runs_done"]
    successes = mission["successes"] - 1  # a new run of the benchmark, one success fewer
    mission["successes"] = successes
    (results / "mission.json").write_text(json.dumps(mission), encoding="utf-8")
    paths = ("--results-dir", results, "--page", page, "--readme", readme)

    stale = run("--check", *paths)
    assert stale.returncode == 1, "--check passed pages that no longer match the JSON"
    assert str(page) in stale.stderr and str(readme) in stale.stderr

    assert run(*paths).returncode == 0
    assert run("--check", *paths).returncode == 0
    figure = f"| {successes} of {runs} |"
    assert figure in page.read_text(encoding="utf-8")
    assert f"| {successes} of {runs} (" in readme.read_text(encoding="utf-8")


def test_every_result_file_has_its_section_and_an_unknown_one_is_refused(
        tmp_path: Path) -> None:
    text = (ROOT / "docs" / "results.md").read_text(encoding="utf-8")
    for result in sorted(RESULTS.glob("*.json")):
        assert f"(../benchmarks/results/{result.name})" in text, f"no section for {result.name}"

    results, page, readme = copy_of_the_inputs(tmp_path)
    (results / "bench_nobody_described.json").write_text("{}", encoding="utf-8")
    done = run("--check", "--results-dir", results, "--page", page, "--readme", readme)
    assert done.returncode != 0
    assert "bench_nobody_described.json" in done.stderr


def test_the_readme_outside_the_generated_block_is_left_as_it_is(tmp_path: Path) -> None:
    results, page, readme = copy_of_the_inputs(tmp_path)
    before = readme.read_text(encoding="utf-8")
    readme.write_text(before.replace("# quadmission\n", "# quadmission (edited)\n", 1),
                      encoding="utf-8")
    assert run("--results-dir", results, "--page", page, "--readme", readme).returncode == 0
    assert readme.read_text(encoding="utf-8").startswith("# quadmission (edited)\n")


def test_make_sim_timings_are_shown_against_their_target_and_older_results_lack_the_row(
        tmp_path: Path) -> None:
    results, page, readme = copy_of_the_inputs(tmp_path)
    paths = ("--results-dir", results, "--page", page, "--readme", readme)
    speed = json.loads((results / "mission_speed.json").read_text(encoding="utf-8"))
    speed["make_sim"] = {"command": "make sim OUT=<tmp>", "wall_s": 119.6,
                         "wall_s_runs": [119.6, 125.2, 101.0], "exit_codes": [0, 0, 0],
                         "bag_messages": [1, 1, 1], "target_s": 120.0,
                         "every_run_under_target": False}
    (results / "mission_speed.json").write_text(json.dumps(speed), encoding="utf-8")
    assert run(*paths).returncode == 0
    text = page.read_text(encoding="utf-8")
    assert "| `make sim` (with its bag), wall time, median of 3 runs | 119.6 s (runs: 119.6, " \
           "125.2, 101.0 s; exit codes 0, 0, 0) | under 120 s: NOT every run under it" in text

    del speed["make_sim"]  # a result from before --make-sim-runs
    (results / "mission_speed.json").write_text(json.dumps(speed), encoding="utf-8")
    assert run(*paths).returncode == 0
    text = page.read_text(encoding="utf-8")
    assert "real-time factor (simulated / wall seconds)" in text
    section = text.split("## Contest mission speed")[1].split("\n## ")[0]
    assert "| `make sim` (with its bag)" not in section
