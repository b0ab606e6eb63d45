"""Mutation testing of chosen modules with mutmut 3, and the kill rate of each (``make mutate``).

Usage (from the repository root; ``make mutate`` passes the Makefile's variables)::

    python tools/mutate.py [--max-children N] [--min-kill-percent P] [--survivors]
                           PATH[:NAME,...][=TEST,...] ...

Each PATH is a module (``sim/fcu/control.py``) or a package folder
(``flight_control/behaviours/``) to mutate; ``:NAME,NAME`` keeps only those functions and
classes of a module (``sim/fcu/control.py:mix_with_desaturation,_desaturate``), a
``Class.method`` name one method (``flight_control/bridge_node.py:FcuBridgeNode.to_fcu_us``).
Its tests mirror the layout, as everywhere in this repository:
``tests/sim/fcu/test_control*.py`` for a module, ``tests/<folder>/`` for a folder;
``PATH=tests/a.py,tests/b.py`` names them instead. Only those tests run (mutmut
then runs, per mutant, only the tests that call the mutated function), which keeps a run
short. The static settings (what is copied into ``./mutants``, pytest options) live in
``[tool.mutmut]`` of pyproject.toml; this script adds the modules and their tests, runs
``mutmut run``, then prints killed/total per module and exits 1 when a module's kill rate
is below ``--min-kill-percent``. Survivors: ``.venv/bin/mutmut results`` and
``.venv/bin/mutmut show NAME`` (equivalent mutants are listed in tests/MUTANTS.md).

Every run tests every selected mutant again, so the figures are those of the code and
tests as they are. ``--survivors`` re-tests only the mutants not yet killed (quick while
writing tests). Results are kept in ./mutants; ``make mutate-clean`` removes them.
"""

from __future__ import annotations

import argparse
import dataclasses
import fnmatch
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
    names: tuple[str, ...] = ()
    """Functions or classes of the module to mutate; empty: all of it."""

    @property
    def module(self) -> str:
        return self.path.removesuffix(".py").replace("/", ".")

    def globs(self) -> list[str]:
        """mutmut mutant-name patterns of the target (``module.x_func__mutmut_3``,
        ``module.xǁClassǁmethod__mutmut_1``)."""
        if not self.names:
            return [f"{self.module}.*"]
        return [pattern for name in self.names for pattern in self._name_globs(name)]

    def _name_globs(self, name: str) -> tuple[str, ...]:
        cls, dot, method = name.partition(".")
        if dot:  # one method of a class
            return (f"{self.module}.xǁ{cls}ǁ{method}__mutmut_*",)
        return (f"{self.module}.x_{name}__mutmut_*", f"{self.module}.xǁ{name}ǁ*")

    def selects(self, mutant_name: str) -> bool:
        return any(fnmatch.fnmatchcase(mutant_name, g) for g in self.globs())


def parse_target(spec: str, root: Path) -> Target:
    """``PATH[:NAME,NAME][=TEST,TEST]``; tests default to the mirrored ``tests/`` location."""
    path_names, _, explicit = spec.partition("=")
    path, _, names_text = path_names.partition(":")
    names = tuple(n for n in names_text.split(",") if n)
    if names and not path.endswith(".py"):
        raise SystemExit(f"mutate: {spec}: ':NAME' selects functions of a module, not a folder")
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
    return Target(path.rstrip("/"), tests, names)


def only_mutate_pattern(target: Target) -> str:
    """mutmut's ``only_mutate`` glob for a target."""
    return target.path if target.path.endswith(".py") else f"{target.path}/*"


def _exit_codes(metas: list[Path], target: Target) -> dict[str, int | None]:
    """mutmut's recorded exit code of each of the target's mutants."""
    codes: dict[str, int | None] = {}
    for meta in metas:
        if meta.exists():
            recorded = json.loads(meta.read_text(encoding="utf-8"))["exit_code_by_key"]
            codes.update({k: v for k, v in recorded.items() if target.selects(k)})
    return codes


def _metas(root: Path, target: Target) -> list[Path]:
    if target.path.endswith(".py"):
        return [root / "mutants" / f"{target.path}.meta"]
    return sorted((root / "mutants" / target.path).rglob("*.py.meta"))


def survivors(root: Path, targets: list[Target], untested_only: bool = False) -> list[str]:
    """The selected mutants not (yet) caught, from the last run; or only the untested."""
    from mutmut.stats import status_by_exit_code

    left = {"not checked"} if untested_only else None
    return [
        name
        for target in targets
        for name, code in _exit_codes(_metas(root, target), target).items()
        if status_by_exit_code[code] not in _KILLED
        and (left is None or status_by_exit_code[code] in left)
    ]


def kill_rates(root: Path, targets: list[Target]) -> list[tuple[str, int, int, int]]:
    """(path, killed, survived, total) per target, from mutmut's ``mutants/*.meta`` files."""
    from mutmut.stats import status_by_exit_code

    rows = []
    for target in targets:
        metas = _metas(root, target)
        statuses = [status_by_exit_code[code] for code in _exit_codes(metas, target).values()]
        counted = [s for s in statuses if s != "skipped"]
        killed = sum(1 for s in counted if s in _KILLED)
        survived = sum(1 for s in counted if s not in _KILLED and s != "not checked")
        label = f"{target.path}:{','.join(target.names)}" if target.names else target.path
        rows.append((label, killed, survived, len(counted)))
    return rows


def refresh_copies(root: Path, source_paths: list[Path], targets: list[Target]) -> None:
    """Drop stale copies in ./mutants of the files that are not mutated.

    mutmut copies a source file into ./mutants only when no copy is there yet, so a module
    edited (or deleted) since the last run would otherwise be imported in its old form.
    The mutated modules themselves mutmut regenerates when they change; but a plain copy
    of a module to mutate now (left by a run that did not mutate it, over an earlier
    mutated copy or not) is newer than its source, and mutmut would skip it: it is
    dropped too.
    """
    mutated = {t.path for t in targets if t.path.endswith(".py")}
    folders = [t.path + "/" for t in targets if not t.path.endswith(".py")]
    for source_path in source_paths:
        for copy in (root / "mutants" / source_path).rglob("*"):
            rel = copy.relative_to(root / "mutants").as_posix()
            if not copy.is_file() or rel.endswith(".meta") or "__pycache__" in rel:
                continue
            if rel in mutated or any(rel.startswith(f) for f in folders):
                source = root / rel
                if rel.endswith(".py") and source.is_file() and (
                    not Path(f"{copy}.meta").exists() or source.read_bytes() == copy.read_bytes()
                ):
                    # copied plain by a run that did not mutate it (a mutated copy always
                    # differs from its source): newer than the source, mutmut would take it
                    # as mutated already ("unmodified") and generate nothing
                    copy.unlink()
                continue
            source = root / rel
            if not source.is_file() or source.read_bytes() != copy.read_bytes():
                copy.unlink()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("paths", nargs="+", help="module or folder to mutate [=TEST,TEST]")
    parser.add_argument("--max-children", type=int, default=1, help="parallel mutant runs")
    parser.add_argument("--min-kill-percent", type=float, default=90.0)
    parser.add_argument("--survivors", action="store_true", help="re-test only the survivors")
    parser.add_argument("--report-only", action="store_true", help="print the last results")
    args = parser.parse_args(argv)
    root = Path.cwd()
    if not (root / "pyproject.toml").exists():
        parser.error("run from the repository root (where pyproject.toml is)")
    targets = [parse_target(spec, root) for spec in args.paths]

    if not args.report_only:
        import mutmut.configuration as mutmut_configuration

        base = mutmut_configuration.config()  # [tool.mutmut] of pyproject.toml
        refresh_copies(root, base.source_paths, targets)
        mutmut_configuration._config = dataclasses.replace(
            base,
            only_mutate=[only_mutate_pattern(t) for t in targets],
            pytest_add_cli_args_test_selection=sorted({t for x in targets for t in x.tests}),
        )
        from mutmut.__main__ import cli

        run_args = ["run", "--max-children", str(args.max_children)]
        if not args.survivors:
            selections = [[g for t in targets for g in t.globs()]]
        else:  # survivors first (this also regenerates edited functions), then the untested
            selections = [survivors(root, targets), []]
        for i, selection in enumerate(selections):
            if args.survivors and i == 1:
                selection = survivors(root, targets, untested_only=True)
            if not selection:
                continue
            try:
                cli([*run_args, *selection], standalone_mode=False)
            except SystemExit as stop:
                if stop.code:
                    return int(stop.code) if isinstance(stop.code, int) else 1

    failed = False
    print(f"\n{'module':<44} {'killed':>7} {'survived':>9} {'total':>6}  kill rate")
    for path, killed, survived, total in kill_rates(root, targets):
        rate = 100.0 * killed / total if total else 0.0
        low = rate < args.min_kill_percent
        failed |= low
        flag = f"  < {args.min_kill_percent:g} %" if low else ""
        print(f"{path:<44} {killed:>7} {survived:>9} {total:>6}  {rate:5.1f} %{flag}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
