"""Pictures of a contest mission (matplotlib, Agg): the path over the map, the altitude
against its setpoint, and the state machine's timeline."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from quadmission.evaluation.mission import Landing
from quadmission.evaluation.tracking import FloatArray
from quadmission.reports.plots import FLOWN_COLOUR, SETPOINT_COLOUR, draw_arena
from sim.arena import ArenaSpec
from sim.world import Crash, Trajectory


@dataclass(frozen=True)
class MissionPicture:
    """What the three pictures draw."""

    title: str
    went_wrong: bool
    arena: ArenaSpec  # the published field (a removed pad is still drawn, and crossed out)
    altitude: float  # m, cruise altitude
    setpoint_t: FloatArray
    setpoint: FloatArray  # m, (N, 3)
    truth: Trajectory
    landings: Sequence[Landing]
    sequence: Sequence[int]
    robot_xy: tuple[float, float] | None  # m, where the target robot was when found
    robot_id: int
    timeline: Sequence[tuple[float, str]]  # (t [s], nested state)
    end_s: float
    removed_pad: int | None = None
    crash: Crash | None = None


def _figure(width: float, height: float, picture: MissionPicture, what: str) -> Figure:
    fig = Figure(figsize=(width, height), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    fig.suptitle(f"{what}: {picture.title}", fontsize=11,
                 color="tab:red" if picture.went_wrong else "black")
    return fig


def save_path(path: Path, picture: MissionPicture) -> None:
    """Top view: the arena, setpoints and flown path, the sequence, touchdowns, robot."""
    fig = _figure(11.0, 8.5, picture, "xy path")
    ax = fig.add_subplot()
    draw_arena(ax, picture.arena, picture.altitude)
    sp, truth = picture.setpoint, picture.truth
    finite = np.all(np.isfinite(sp[:, :2]), axis=1)
    ax.plot(sp[finite, 0], sp[finite, 1], ".", color=SETPOINT_COLOUR, markersize=1.5,
            label="setpoint (/fcu/setpoint)", zorder=4)
    if len(truth):
        ax.plot(truth.position[:, 0], truth.position[:, 1], color=FLOWN_COLOUR, linewidth=1.0,
                label="flown (ground truth)", zorder=5)
    for order, pad in enumerate(picture.sequence, start=1):
        x, y = picture.arena.pad(pad).center
        ax.annotate(f"#{order}", (x, y), xytext=(x + 0.45, y - 0.45), fontsize=10,
                    color="tab:blue", fontweight="bold", zorder=8)
    for d in picture.landings:
        if d.touchdown_xy is not None:
            ax.plot(*d.touchdown_xy, marker="+", markersize=12, mew=2, zorder=7,
                    color="tab:green" if d.inside else "tab:red")
    if picture.removed_pad is not None:
        x, y = picture.arena.pad(picture.removed_pad).center
        ax.plot(x, y, marker="x", markersize=22, mew=3, color="tab:red", zorder=6,
                label=f"pad {picture.removed_pad} removed")
    if picture.robot_xy is not None:
        ax.plot(*picture.robot_xy, marker="s", markersize=10, color="tab:purple", zorder=7,
                label=f"robot {picture.robot_id} when found")
    if picture.crash is not None:
        cx, cy, _ = picture.crash.position
        ax.plot(cx, cy, marker="X", color="black", markersize=14, zorder=9,
                label=f"crash: {picture.crash.reason}")
    sx, sy = picture.arena.field.size[0], picture.arena.field.size[1]
    t = picture.arena.field.wall_thickness
    ax.set_xlim(-t - 0.2, sx + t + 0.2)
    ax.set_ylim(-t - 0.2, sy + t + 0.2)
    ax.set_aspect("equal")
    ax.set_xlabel("x east [m]")
    ax.set_ylabel("y north [m]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.07), ncol=4, fontsize=8,
              frameon=False)
    fig.savefig(path)


def save_altitude(path: Path, picture: MissionPicture) -> None:
    """z against its setpoint over the whole run (seed 003, Figure 13)."""
    fig = _figure(11.0, 4.0, picture, "altitude")
    ax = fig.add_subplot()
    finite = np.isfinite(picture.setpoint[:, 2])
    ax.plot(picture.setpoint_t[finite], picture.setpoint[finite, 2], ".", markersize=1.5,
            color=SETPOINT_COLOUR, label="setpoint z")
    if len(picture.truth):
        ax.plot(picture.truth.t, picture.truth.position[:, 2], color=FLOWN_COLOUR,
                linewidth=1.0, label="flown z (ground truth)")
    for d in picture.landings:
        ax.axvline(d.t_s, color="tab:green" if d.inside else "tab:red", alpha=0.4)
    ax.set_xlabel("sim time [s]")
    ax.set_ylabel("z [m]")
    ax.set_xlim(0.0, picture.end_s)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    fig.savefig(path)


def save_timeline(path: Path, picture: MissionPicture) -> None:
    """Each state the machine was in, as a bar from entry to exit."""
    fig = _figure(11.0, 5.0, picture, "state machine")
    ax = fig.add_subplot()
    names: list[str] = []
    for _, state in picture.timeline:
        if state not in names:
            names.append(state)
    rows = {name: i for i, name in enumerate(names)}
    ends = [t for t, _ in picture.timeline[1:]] + [picture.end_s]
    cmap = {"mission.pad": "tab:blue", "mission": "tab:green", "returning": "tab:orange",
            "paused": "0.6", "completed": "tab:green", "stopped": "tab:red",
            "landed": "tab:red", "landing_now": "tab:red"}
    for (t0, state), t1 in zip(picture.timeline, ends, strict=True):
        colour = next((c for prefix, c in cmap.items() if state.startswith(prefix)), "0.3")
        ax.barh(rows[state], max(t1 - t0, picture.end_s / 400.0), left=t0, height=0.6,
                color=colour)
    ax.set_yticks(range(len(names)), names, fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("sim time [s]")
    ax.set_xlim(0.0, picture.end_s)
    ax.grid(True, axis="x", alpha=0.3)
    fig.savefig(path)


__all__ = ["MissionPicture", "save_altitude", "save_path", "save_timeline"]
