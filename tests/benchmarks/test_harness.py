"""benchmarks/_harness.py: the scaffolding every bench_*.py shares (its --out, the JSON it
writes, the host it ran on), and that every script uses it rather than its own copy."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from benchmarks import _harness
from benchmarks._harness import (
    OPTIONAL,
    REQUIRED,
    RESULTS_DIR,
    bench_parser,
    host,
    reference_loop_s,
    seed_list,
    write_result,
)

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
SCRIPTS = sorted(BENCHMARKS.glob("bench_*.py"))


def test_out_defaults_to_the_results_file_of_the_benchmark() -> None:
    parser = bench_parser("Title line.\n\nMore.", "fcu")
    assert parser.description == "Title line."
    assert parser.parse_args([]).out == RESULTS_DIR / "fcu.json"
    assert RESULTS_DIR == BENCHMARKS / "results"
    assert parser.parse_args(["--out", "x.json"]).out == Path("x.json")


def test_out_can_be_required_or_left_out() -> None:
    with pytest.raises(SystemExit):
        bench_parser(__doc__, REQUIRED).parse_args([])
    assert bench_parser(__doc__, OPTIONAL).parse_args([]).out is None


def test_the_result_is_written_with_its_folder_and_a_final_newline(tmp_path: Path) -> None:
    out = tmp_path / "new" / "folder" / "r.json"
    text = write_result(out, {"ratio": 1.5, "runs": [1, 2]})
    assert out.read_text(encoding="utf-8") == text
    assert text.endswith("}\n") and json.loads(text) == {"ratio": 1.5, "runs": [1, 2]}
    assert write_result(out, {"a": 1}, indent=1) == '{\n "a": 1\n}\n'
    assert write_result(None, {"a": 1}) == '{\n  "a": 1\n}\n'  # printed only


def test_a_nan_is_kept_and_named_on_stderr(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.json"
    write_result(out, {"ratio": math.nan})
    assert "NaN" in out.read_text(encoding="utf-8")
    assert "result['ratio']: NaN" in capsys.readouterr().err


def test_a_strict_result_refuses_a_nan_naming_it_and_keeps_the_last_file(
        tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    write_result(out, {"runs": [{"rtf": 2.0}]}, allow_nan=False)
    with pytest.raises(ValueError, match=r"result\['runs'\]\[1\]\['rtf'\]: NaN"):
        write_result(out, {"runs": [{"rtf": 2.0}, {"rtf": math.nan}]}, allow_nan=False)
    with pytest.raises(ValueError, match=r"result\['limit'\]: NaN or infinity"):
        write_result(None, {"limit": math.inf}, allow_nan=False)
    assert json.loads(out.read_text(encoding="utf-8")) == {"runs": [{"rtf": 2.0}]}


#: the scripts whose results were strict JSON before the harness (json.dumps(...,
#: allow_nan=False)); the others wrote NaN as Python does, and still do, with a warning
STRICT = ("bench_campaign", "bench_mission", "bench_navigate_seeds", "bench_square_seeds")


@pytest.mark.parametrize("name", STRICT)
def test_the_scripts_with_strict_results_refuse_nan(name: str) -> None:
    text = (BENCHMARKS / f"{name}.py").read_text(encoding="utf-8")
    calls = re.findall(r"write_result\((.*)\)\n", text)
    assert calls and all(c.endswith("allow_nan=False") for c in calls), calls


def test_the_host_names_python_machine_cpus_and_the_loads_the_script_took() -> None:
    h = host(load_1min=0.5)
    assert {"python", "machine", "cpus"} <= set(h)
    assert h["load_1min"] == 0.5


@pytest.mark.parametrize(("text", "seeds"), [("1-3", [1, 2, 3]), ("3,7", [3, 7]),
                                            ("2-4,6", [2, 3, 4, 6]), ("5", [5])])
def test_seed_lists(text: str, seeds: list[int]) -> None:
    assert seed_list(text) == seeds


def test_the_reference_loop_is_timed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_harness, "REFERENCE_LOOP_ITEMS", 1000)
    assert 0 < reference_loop_s(repeats=2) < math.inf


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_every_benchmark_takes_its_scaffolding_from_the_harness(script: Path) -> None:
    text = script.read_text(encoding="utf-8")
    assert "from _harness import" in text and "bench_parser(__doc__" in text
    for own_copy in ('add_argument("--out"', "ArgumentParser(", ".write_text(json.dumps("):
        assert own_copy not in text, f"{script.name} writes its own {own_copy}"
