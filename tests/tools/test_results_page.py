"""docs/results.md and the README's headline table are what tools/results_page.py makes of
benchmarks/results/*.json now: a benchmark re-run without `make docs` fails here. Each
result's section lives beside its benchmark (benchmarks/sections/), and the page is made
with the standard library only: every run of the tool here is without site-packages."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

from benchmarks.sections import registry

ROOT = Path(__file__).resolve().parents[2]
TOOL = ROOT / "tools" / "results_page.py"
RESULTS = ROOT / "benchmarks" / "results"
#: Python without site-packages (-S) nor the environment (-I): the standard library only, as
#: `make docs` runs it without .venv
STDLIB_ONLY = ("-I", "-S")


def run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, *STDLIB_ONLY, str(TOOL), *map(str, args)],
                          cwd=ROOT, capture_output=True, text=True, timeout=120, check=False)


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


def test_the_page_is_made_with_the_standard_library_only() -> None:
    bare = subprocess.run([sys.executable, *STDLIB_ONLY, "-c", "import numpy"],
                          capture_output=True, text=True, timeout=60, check=False)
    assert bare.returncode != 0, "numpy importable without site-packages: nothing is proved"
    done = run("--check")
    assert "ModuleNotFoundError" not in done.stderr, \
        f"a section imports more than the standard library:\n{done.stderr}"


def test_a_new_benchmark_result_makes_the_pages_stale_until_regenerated(tmp_path: Path) -> None:
    results, page, readme = copy_of_the_inputs(tmp_path)
    mission = json.loads((results / "mission.json").read_text(encoding="utf-8"))
    runs = mission["runs_done"]
    successes = mission["successes"] - 1  # a new run of the benchmark, one success fewer
    mission["successes"] = successes
    (results / "mission.json").write_text(json.dumps(mission), encoding="utf-8")
    campaign = json.loads((results / "campaign_arenas.json").read_text(encoding="utf-8"))
    rate = campaign["summary"]["rate"]
    rate["passed"] -= 1  # the README's first row: the arena campaign
    (results / "campaign_arenas.json").write_text(json.dumps(campaign), encoding="utf-8")
    paths = ("--results-dir", results, "--page", page, "--readme", readme)

    stale = run("--check", *paths)
    assert stale.returncode == 1, "--check passed pages that no longer match the JSON"
    assert str(page) in stale.stderr and str(readme) in stale.stderr

    assert run(*paths).returncode == 0
    assert run("--check", *paths).returncode == 0
    figure = f"| {successes} of {runs} |"
    assert figure in page.read_text(encoding="utf-8")
    first_row = readme.read_text(encoding="utf-8").split("|---|---|---|\n")[1].split("\n")[0]
    assert f"| {rate['passed']} of {rate['runs']};" in first_row


def test_every_result_file_has_its_section_beside_the_benchmark_that_wrote_it() -> None:
    entries = registry()
    for result in sorted(RESULTS.glob("*.json")):
        entry = entries.get(result.stem)
        assert entry is not None, f"{result.name} has no section in benchmarks/sections/"
        assert entry.section.source or (ROOT / entry.script).is_file(), \
            f"{result.name}'s section is in {entry.module}.py, but there is no {entry.script}"
    for script in sorted((ROOT / "benchmarks").glob("bench_*.py")):
        name = script.stem.removeprefix("bench_")
        assert (ROOT / "benchmarks" / "sections" / f"{name}.py").is_file(), \
            f"{script.name} has no section module benchmarks/sections/{name}.py"
    text = (ROOT / "docs" / "results.md").read_text(encoding="utf-8")
    for result in sorted(RESULTS.glob("*.json")):
        assert f"(../benchmarks/results/{result.name})" in text, f"no section for {result.name}"


def test_a_result_file_without_a_section_is_refused(tmp_path: Path) -> None:
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


def headline_row(readme: Path, figure: str) -> str:
    rows = readme.read_text(encoding="utf-8").splitlines()
    return next(row for row in rows if row.startswith(f"| {figure}"))


def test_the_astar_headline_leads_with_libtcod_and_gives_the_host_speed_beside_networkx(
        tmp_path: Path) -> None:
    results, page, readme = copy_of_the_inputs(tmp_path)
    paths = ("--results-dir", results, "--page", page, "--readme", readme)
    astar = json.loads((results / "astar.json").read_text(encoding="utf-8"))
    first = astar["resolutions"][0]
    first["rounds"] = 3  # ours takes a quarter of libtcod's time, a fifth to a half by round
    first["time_ratio_vs_tcod_median"] = 0.25
    first["time_ratio_vs_tcod_rounds"] = {"min": 0.2, "median": 0.25, "max": 0.5}
    astar["host"].pop("reference_loop_s", None)  # a run from before the reference loop
    (results / "astar.json").write_text(json.dumps(astar), encoding="utf-8")
    assert run(*paths).returncode == 0
    row = headline_row(readme, "A* at")
    figure, value = row.split(" | ")[:2]
    assert "libtcod's time / ours" in figure
    assert value.startswith("4.0x (2.0-5.0x over 3 rounds); networkx"), value
    assert "host-dependent: this run predates the host-speed reference" in value
    assert "predates the host-speed reference" in page.read_text(encoding="utf-8")

    astar["host"]["reference_loop_s"] = [0.061, 0.0587]
    (results / "astar.json").write_text(json.dumps(astar), encoding="utf-8")
    assert run(*paths).returncode == 0
    value = headline_row(readme, "A* at").split(" | ")[1]
    assert "host-dependent: the host's pure-Python reference loop took 59-61 ms" in value
    assert "predates" not in value


def test_a_campaign_stopped_short_says_how_many_runs_were_flown(tmp_path: Path) -> None:
    results, page, readme = copy_of_the_inputs(tmp_path)
    campaign = json.loads((results / "campaign_arenas.json").read_text(encoding="utf-8"))
    campaign["summary"]["rate"] |= {"runs": 30, "passed": 29}
    (results / "campaign_arenas.json").write_text(json.dumps(campaign), encoding="utf-8")
    assert run("--results-dir", results, "--page", page, "--readme", readme).returncode == 0
    cells = campaign["session"]["cells"]
    value = headline_row(readme, f"contest mission, {cells} random arenas").split(" | ")[1]
    assert value.startswith(f"29 of 30 flown ({cells} planned);"), value
