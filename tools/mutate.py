"""Mutation testing of chosen modules with mutmut 3, and the kill rate of each (``make mutate``).

Usage (from the repository root; ``make mutate`` passes the Makefile's variables)::

    python tools/mutate.py [--max-children N] [--min-kill-percent P] PATH[=TESTS,...] ...

Each PATH is a module (``sim/fcu/control.py``) or a package folder
(``flight_control/behaviours/``) to mutate. Its tests mirror the layout, as everywhere in
this repository: ``tests/sim/fcu/test_control*.py`` for a module, ``tests/<folder>/`` for a
folder; ``PATH=tests/a.py,tests/b.py`` names them instead. Only those tests run (mutmut
then runs, per mutant, only the tests that call the mutated function), which keeps a run
short. The static settings (what is copied into ``./mutants``, pytest options) live in
``[tool.mutmut]`` of pyproject.toml; this script adds the modules and their tests, runs
``mutmut run``, then prints killed/total per module and exits 1 when a module's kill rate
is below ``--min-kill-percent``. Survivors: ``.venv/bin/mutmut results`` and
``.venv/bin/mutmut show NAME`` (equivalent mutants are listed in tests/MUTANTS.md).

Results are kept in ./mutants between runs (mutmut re-tests only what changed);
``make mutate-clean`` removes them.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

_KILLED = {"killed", "timeout", "caught by type check"}
"""mutmut's outcomes that count as caught; "survived", "no tests" and "suspicious" do not."""


@dataclasses.dataclass(frozen=True)
class Target:
    """One module or folder to mutate, and the tests that should catch its mutants."""

    path: str
    tests: tuple[str, ...]


def parse_target(spec: str, root: Path) -> Target:
    """``PATH`` or ``PATH=TEST,TEST``; tests default to the mirrored ``tests/`` location."""
    path, _, explicit = spec.partition("=")
    source = root / path
    if not source.exists():
        raise SystemExit(f"mutate: {path}: no such module or folder")
    if explicit:
        tests = tuple(t for t in explicit.split(",") if t)
    elif source.is_dir():
        tests = (str(Path("tests") / path.rstrip("/")),)
    else:
        rel = Path(path)
        pattern = f"test_{rel.stem}*.py"
        tests = tuple(
            str(p.relative_to(root)) for p in sorted((root / "tests" / rel.parent).glob(pattern))
        )
    missing = [t for t in tests if not (root / t).exists()]
    if not tests or missing:
        raise SystemExit(
            f"mutate: {path}: no tests found ({', '.join(missing) or 'tests/.../' + 'test_*'}); "
            "name them as PATH=TEST,TEST"
        )
    return Target(path.rstrip("/"), tests)


def only_mutate_pattern(target: Target) -> str:
    """mutmut's ``only_mutate`` glob for a target."""
    return target.path if target.path.endswith(".py") else f"{target.path}/*"


def kill_rates(root: Path, targets: list[Target]) -> list[tuple[str, int, int, int]]:
    """(path, killed, survived, total) per target, from mutmut's ``mutants/*.meta`` files."""
    from mutmut.stats import status_by_exit_code

    rows = []
    for target in targets:
        metas = (
            [root / "mutants" / f"{target.path}.meta"]
            if target.path.endswith(".py")
            else sorted((root / "mutants" / target.path).rglob("*.py.meta"))
        )
        statuses: list[str] = []
        for meta in metas:
            if meta.exists():
                codes = json.loads(meta.read_text(encoding="utf-8"))["exit_code_by_key"]
                statuses += [status_by_exit_code[code] for code in codes.values()]
        counted = [s for s in statuses if s != "skipped"]
        killed = sum(1 for s in counted if s in _KILLED)
        survived = sum(1 for s in counted if s not in _KILLED and s != "not checked")
        rows.append((target.path, killed, survived, len(counted)))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("paths", nargs="+", help="module or folder to mutate [=TEST,TEST]")
    parser.add_argument("--max-children", type=int, default=1, help="parallel mutant runs")
    parser.add_argument("--min-kill-percent", type=float, default=90.0)
    parser.add_argument("--report-only", action="store_true", help="print the last results")
    args = parser.parse_args(argv)
    root = Path.cwd()
    if not (root / "pyproject.toml").exists():
        parser.error("run from the repository root (where pyproject.toml is)")
    targets = [parse_target(spec, root) for spec in args.paths]

    if not args.report_only:
        import mutmut.configuration as mutmut_configuration

        base = mutmut_configuration.config()  # [tool.mutmut] of pyproject.toml
        mutmut_configuration._config = dataclasses.replace(
            base,
            only_mutate=[only_mutate_pattern(t) for t in targets],
            pytest_add_cli_args_test_selection=sorted({t for x in targets for t in x.tests}),
        )
        from mutmut.__main__ import cli

        run_args = ["run", "--max-children", str(args.max_children)]
        try:
            cli(run_args, standalone_mode=False)
        except SystemExit as stop:
            if stop.code:
                return int(stop.code) if isinstance(stop.code, int) else 1

    failed = False
    print(f"\n{'module':<40} {'killed':>7} {'survived':>9} {'total':>6}  kill rate")
    for path, killed, survived, total in kill_rates(root, targets):
        rate = 100.0 * killed / total if total else 0.0
        low = rate < args.min_kill_percent
        failed |= low
        flag = f"  < {args.min_kill_percent:g} %" if low else ""
        print(f"{path:<40} {killed:>7} {survived:>9} {total:>6}  {rate:5.1f} %{flag}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
