"""A campaign's plots (matplotlib, Agg): pass rates, touchdown errors, reaction times and
wall time per run, each a PNG in the campaign's folder, units on every axis."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from quadmission.campaigns.summary import CampaignSummary, Rate

__all__ = ["PICTURES", "save_plots"]

PASS_RATE_PNG = "pass_rate.png"
TOUCHDOWN_PNG = "touchdown_error.png"
REACTION_PNG = "reaction_time.png"
WALL_TIME_PNG = "wall_time.png"
#: (caption, file name) of each picture, in the summary's order.
PICTURES: tuple[tuple[str, str], ...] = (
    ("pass rate per fault kind and per lighting", PASS_RATE_PNG),
    ("touchdown error of every landing", TOUCHDOWN_PNG),
    ("reaction time per fault kind", REACTION_PNG),
    ("wall time per run", WALL_TIME_PNG),
)
PAD_HALF_CM = 50.0  # a touchdown closer than this to the pad's centre is on the 1 m pad


def _save(fig: Figure, path: Path) -> None:
    fig.tight_layout()
    FigureCanvasAgg(fig).print_png(str(path))


def _bars(ax: Axes, rates: Sequence[Rate], title: str) -> None:
    names = [r.group for r in rates]
    values = [100.0 * r.rate for r in rates]
    bars = ax.bar(names, values, color=["tab:green" if r.rate == 1.0 else "tab:orange"
                                        for r in rates])
    for bar, r in zip(bars, rates, strict=True):
        ax.annotate(f"{r.passed}/{r.runs}", (bar.get_x() + bar.get_width() / 2, bar.get_height()),
                    ha="center", va="bottom", fontsize=8)
    ax.set_ylim(0, 110)
    ax.set_ylabel("runs passed [%]")
    ax.set_title(title)
    ax.tick_params(axis="x", labelrotation=30)


def _grouped(pairs: Iterable[tuple[str, float | None]]) -> dict[str, list[float]]:
    """The values of each group, in order, without the unknown ones."""
    out: dict[str, list[float]] = {}
    for group, value in pairs:
        if value is not None:
            out.setdefault(group, []).append(value)
    return out


def _single(path: Path, size: tuple[float, float], labels: tuple[str, str],
            draw: Callable[[Axes], None] | None, empty: str) -> None:
    """One plot: ``draw`` on its axes (None: say ``empty`` instead), ``labels`` x and y."""
    fig = Figure(figsize=size)
    ax = fig.subplots()
    if draw is None:
        ax.text(0.5, 0.5, empty, ha="center", va="center", transform=ax.transAxes)
    else:
        draw(ax)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    _save(fig, path)


def save_plots(summary: CampaignSummary, rows: Sequence[dict[str, Any]], out: Path) -> None:
    """Write :data:`PICTURES` into ``out``."""
    fig = Figure(figsize=(10, 4))
    left, right = fig.subplots(1, 2)
    _bars(left, [k.rate for k in summary.by_kind], "per fault kind")
    _bars(right, summary.by_lighting, "per lighting")
    _save(fig, out / PASS_RATE_PNG)

    errors_cm = [100.0 * e for row in rows for e in row["touchdown_errors_m"]]

    def touchdowns(ax: Axes) -> None:
        ax.hist(errors_cm, bins=20, color="tab:blue")
        ax.axvline(PAD_HALF_CM, color="tab:red", linestyle="--", label="pad edge (50 cm)")
        ax.legend()

    _single(out / TOUCHDOWN_PNG, (6, 4), ("touchdown error, true touchdown to pad centre "
                                          "[cm]", "landings"),
            touchdowns if errors_cm else None, "no landings on pads")

    by_kind = _grouped((kind, t) for row in rows
                       for kind, t in zip(row["fault_kinds"], row["reaction_s"], strict=False))

    def reactions(ax: Axes) -> None:
        kinds = sorted(by_kind)
        ax.boxplot([by_kind[k] for k in kinds], tick_labels=kinds)
        for i, k in enumerate(kinds, start=1):  # every run, over its box
            ax.plot([i] * len(by_kind[k]), by_kind[k], "o", color="tab:blue", alpha=0.5)
        ax.set_ylim(bottom=0.0)
        ax.tick_params(axis="x", labelrotation=30)

    _single(out / REACTION_PNG, (8, 4), ("fault kind", "reaction time after the fault [s]"),
            reactions if by_kind else None, "no reactions observed")

    by_scenario = _grouped((row["scenario"], row["wall_s"]) for row in rows)

    def wall_times(ax: Axes) -> None:
        ax.hist(list(by_scenario.values()), bins=20, stacked=True, label=list(by_scenario))
        ax.legend()

    _single(out / WALL_TIME_PNG, (6, 4), ("wall time per run [s]", "runs"),
            wall_times if by_scenario else None, "no runs")
