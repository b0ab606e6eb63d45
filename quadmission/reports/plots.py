"""Pictures of a flight for a person to read (matplotlib, Agg: no display needed).

:func:`save_path_figure` draws ``path.png``: a top view of the arena around the flight
(metre axes, walls, obstacles, pads, the start pad, setpoint against flown path, the
crash point if any), the altitude against time, and the position error against time (against
what the :class:`~quadmission.evaluation.tracking.Tracking` says).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from quadmission.evaluation.tracking import FloatArray, Tracking
from sim.arena import PAD_SIZE, ArenaSpec
from sim.world import Crash, Trajectory

SETPOINT_COLOUR = "tab:blue"
FLOWN_COLOUR = "tab:red"
PLAN_COLOUR = "0.55"
VIEW_MARGIN = 1.5  # m, shown around the flight in the top view


@dataclass(frozen=True)
class FlightPicture:
    """What :func:`save_path_figure` draws."""

    title: str
    went_wrong: bool  # a crash or a failure: the title turns red
    arena: ArenaSpec
    altitude: float  # m, the flight altitude (tall and low obstacles are told apart by it)
    plan: Sequence[tuple[float, float]]  # the planned outline, closed
    setpoint_t: FloatArray  # s, every setpoint streamed
    setpoint: FloatArray  # m, (N, 3)
    truth: Trajectory
    tracking: Tracking
    crash: Crash | None = None


def _view(picture: FlightPicture) -> tuple[tuple[float, float], tuple[float, float]]:
    points = [np.asarray(picture.plan, dtype=np.float64).reshape(-1, 2)]
    if len(picture.truth):
        points.append(picture.truth.position[:, :2])
    xy = np.vstack(points)
    t = picture.arena.field.wall_thickness
    sx, sy = picture.arena.field.size[0], picture.arena.field.size[1]
    edge_lo = np.array([-t - 0.1, -t - 0.1])
    edge_hi = np.array([sx + t + 0.1, sy + t + 0.1])
    lo = xy.min(axis=0) - VIEW_MARGIN
    hi = xy.max(axis=0) + VIEW_MARGIN
    # near a wall: show the wall whole
    lo = np.where(lo < VIEW_MARGIN / 2, edge_lo, lo)
    hi = np.where(hi > edge_hi - t - VIEW_MARGIN / 2, edge_hi, hi)
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


def _draw_arena(ax: Axes, picture: FlightPicture) -> None:
    draw_arena(ax, picture.arena, picture.altitude)


def draw_arena(ax: Axes, arena: ArenaSpec, altitude: float) -> None:
    """Walls, pads (the start pad outlined), obstacles (told apart by ``altitude``) and the
    robots' paths, in map-frame metres."""
    sx, sy = arena.field.size[0], arena.field.size[1]
    t = arena.field.wall_thickness
    for x, y, w, h in ((-t, -t, t, sy + 2 * t), (sx, -t, t, sy + 2 * t),
                       (0.0, -t, sx, t), (0.0, sy, sx, t)):
        ax.add_patch(Rectangle((x, y), w, h, color="0.1", zorder=2,
                               label="wall" if x == -t and y == -t else None))
    for pad in arena.pads:
        start = pad.id == arena.start_pad
        x, y = pad.center
        ax.add_patch(Rectangle((x - PAD_SIZE / 2, y - PAD_SIZE / 2), PAD_SIZE, PAD_SIZE,
                               facecolor="#9fd3f0", edgecolor="tab:green" if start else "none",
                               linewidth=2.5 if start else 0, zorder=1))
        ax.text(x, y + PAD_SIZE / 2 - 0.05, f"start pad {pad.id}" if start else f"pad {pad.id}",
                ha="center", va="top", fontsize=8, color="0.2", zorder=3, clip_on=True)
    low_label = tall_label = False
    for box in arena.obstacles:
        r = box.footprint
        tall = box.blocks_flight(altitude)
        label = None
        if tall and not tall_label:
            label, tall_label = f"obstacle above {altitude:g} m", True
        elif not tall and not low_label:
            label, low_label = "low obstacle (flown over)", True
        ax.add_patch(Rectangle((r.xmin, r.ymin), r.xmax - r.xmin, r.ymax - r.ymin,
                               facecolor="0.35" if tall else "0.8", edgecolor="0.2",
                               hatch=None if tall else "//", zorder=2, label=label))
        ax.text((r.xmin + r.xmax) / 2, (r.ymin + r.ymax) / 2, f"{box.height:g} m",
                ha="center", va="center", fontsize=7, color="white" if tall else "0.1",
                zorder=3, clip_on=True)
    for i, robot in enumerate(arena.robots):
        path = np.array([*robot.path, robot.path[0]] if robot.loop else robot.path)
        ax.plot(path[:, 0], path[:, 1], ":", color="tab:purple", linewidth=1.5, zorder=2,
                label="robot path" if i == 0 else None)


def save_path_figure(path: Path, picture: FlightPicture) -> None:
    """Write ``picture`` as a PNG at ``path``."""
    fig = Figure(figsize=(13.0, 7.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(2, 2, width_ratios=(1.15, 1.0))
    top = fig.add_subplot(grid[:, 0])
    alt = fig.add_subplot(grid[0, 1])
    err = fig.add_subplot(grid[1, 1], sharex=alt)
    fig.suptitle(picture.title, fontsize=12,
                 color="tab:red" if picture.went_wrong else "black")

    _draw_arena(top, picture)
    plan = np.asarray(picture.plan, dtype=np.float64).reshape(-1, 2)
    top.plot(plan[:, 0], plan[:, 1], "--", color=PLAN_COLOUR, linewidth=1.0, label="planned square")
    sp, truth = picture.setpoint, picture.truth
    finite = np.all(np.isfinite(sp[:, :2]), axis=1)
    top.plot(sp[finite, 0], sp[finite, 1], color=SETPOINT_COLOUR, linewidth=2.0,
             label="setpoint (/fcu/setpoint)", zorder=4)
    if len(truth):
        top.plot(truth.position[:, 0], truth.position[:, 1], color=FLOWN_COLOUR, linewidth=1.2,
                 label="flown (ground truth)", zorder=5)
    start = plan[0]
    top.plot(*start, marker="o", color="tab:green", markersize=8, zorder=6, label="take-off")
    if picture.crash is not None:
        cx, cy, _ = picture.crash.position
        top.plot(cx, cy, marker="X", color="black", markersize=14, zorder=7,
                 label=f"crash: {picture.crash.reason}")
    (x0, x1), (y0, y1) = _view(picture)
    top.set_xlim(x0, x1)
    top.set_ylim(y0, y1)
    top.set_aspect("equal")
    top.set_xlabel("x east [m]")
    top.set_ylabel("y north [m]")
    top.set_title(f"top view, arena {picture.arena.name}")
    top.grid(True, alpha=0.3)
    top.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=3, fontsize=8,
               frameon=False)

    window = picture.tracking.window
    for ax in (alt, err):
        if np.isfinite(window[1]) and window[1] > window[0]:
            ax.axvspan(window[0], window[1], color="0.92", zorder=0)
        ax.grid(True, alpha=0.3)
    z_ok = np.isfinite(picture.setpoint_t) & np.isfinite(sp[:, 2])
    alt.plot(picture.setpoint_t[z_ok], sp[z_ok, 2], color=SETPOINT_COLOUR, linewidth=2.0,
             label="setpoint")
    if len(truth):
        alt.plot(truth.t, truth.position[:, 2], color=FLOWN_COLOUR, linewidth=1.2,
                 label="flown")
    if picture.crash is not None:
        alt.axvline(picture.crash.t_s, color="black", linestyle="--", label="crash")
    alt.set_ylabel("altitude z [m]")
    alt.set_title("altitude (grey: the square, where the RMSE is taken)")
    alt.legend(loc="best", fontsize=8)

    tr = picture.tracking
    if len(tr.t):
        err.plot(tr.t, tr.error_xy * 100.0, color="tab:orange", label="horizontal |e_xy|")
        err.plot(tr.t, np.abs(tr.error[:, 2]) * 100.0, color="tab:cyan", label="vertical |e_z|")
        err.legend(loc="best", fontsize=8)
    else:
        err.text(0.5, 0.5, "no flight on the square to compare", ha="center",
                 va="center", transform=err.transAxes)
    if picture.crash is not None:
        err.axvline(picture.crash.t_s, color="black", linestyle="--")
    err.set_xlabel("simulated time [s]")
    err.set_ylabel("error flown - reference [cm]")
    err.set_title(f"position error against {tr.against}")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)


__all__ = ["FlightPicture", "draw_arena", "save_path_figure"]
