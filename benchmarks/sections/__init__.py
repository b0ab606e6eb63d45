"""The results page's sections: one module per benchmark, named after it, beside it.

``astar.py`` renders ``benchmarks/bench_astar.py``'s JSON (``benchmarks/results/astar.json``):
its ``SECTIONS`` maps each result file's name (without ``.json``) to a :class:`Section`, the
section's prose, its body and, when the figure belongs in the README, its headline rows. A
result written by a command rather than a ``bench_*.py`` script names it as ``source``.
``tools/results_page.py`` only assembles the sections into ``docs/results.md`` and the
README's headline table. Every module here imports the standard library only: the page is
made without .venv (``make docs``), so no renderer may import numpy, MuJoCo or the project.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = ["Entry", "Json", "Results", "Row", "Section", "SectionError", "registry"]

Json = dict[str, Any]
Results = dict[str, Json]
Row = list[str]


class SectionError(ValueError):
    """A section module breaks the contract (no ``SECTIONS``, or a result named twice)."""


@dataclass(frozen=True)
class Section:
    """One section of the results page: a result file rendered as markdown."""

    title: str
    about: str  # what is measured and against what, before the body
    body: Callable[[Json], list[str]]  # the result's JSON -> markdown lines
    source: str | None = None  # what wrote the JSON, when not the bench_*.py beside it
    headline: Callable[[Results], list[Row]] | None = None  # the README's rows, if any


@dataclass(frozen=True)
class Entry:
    """A section with the module it lives in."""

    name: str  # the result file's name, without .json
    module: str  # benchmarks/sections/<module>.py
    section: Section

    @property
    def script(self) -> str:
        """The benchmark beside the module: ``benchmarks/bench_<module>.py``."""
        return f"benchmarks/bench_{self.module}.py"

    @property
    def source(self) -> str:
        """What wrote the JSON, as the page names it."""
        return self.section.source or f"`{self.script}`"


def registry() -> dict[str, Entry]:
    """Every section of every module of this package, by result name."""
    found: dict[str, Entry] = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        sections = getattr(module, "SECTIONS", None)
        if not isinstance(sections, dict):
            raise SectionError(f"benchmarks/sections/{info.name}.py has no SECTIONS dict")
        for name, section in sections.items():
            if name in found:
                raise SectionError(f"{name}.json has two sections: in "
                                   f"{found[name].module}.py and {info.name}.py")
            found[name] = Entry(name, info.name, section)
    return found
