"""Markdown for the results page's sections: numbers, ranges over runs, tables.

Standard library only, like every module of this package: the page is made without .venv.
"""

from __future__ import annotations

from collections.abc import Sequence

from . import Json


def num(value: float, digits: int = 2) -> str:
    return f"{value:.{digits}f}"


def cm(metres: float, digits: int = 1) -> str:
    return f"{metres * 100:.{digits}f} cm"


def pct(share: float, digits: int = 0) -> str:
    return f"{share * 100:.{digits}f} %"


def span(values: Sequence[float], digits: int = 2, unit: str = "") -> str:
    """A range over runs ("4.55-5.43"), or the one value when they agree."""
    low, high = min(values), max(values)
    text = num(low, digits) if num(low, digits) == num(high, digits) else \
        f"{num(low, digits)}-{num(high, digits)}"
    return f"{text} {unit}".rstrip()


def yes(flag: object) -> str:
    return "yes" if flag else "no"


def dash(value: object) -> str:
    return "-" if value is None else str(value)


def ratio(value: float, digits: int = 2) -> str:
    return f"{value:.{digits}f}x"


def table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return [*lines, ""]


def host_line(host: Json | None, load: float | None = None) -> list[str]:
    """Where the figures were measured, when the JSON says."""
    parts = []
    if host:
        if "python" in host:
            parts.append(f"Python {host['python']}")
        if "cpus" in host:
            parts.append(f"{host['cpus']} CPUs")
        load = host.get("load_1min", host.get("load_avg_1min_at_start", load))
    if load is not None:
        parts.append(f"1-min load {load:.1f}")
    return [f"Measured on: {', '.join(parts)}.", ""] if parts else []
