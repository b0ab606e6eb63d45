"""The field as the operator page draws it: plain data, given by whoever knows the arena
(the app layer, from the arena file; or a launch). The ground station never reads the
simulator; this is what a contest's organisers hand the team before the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Box:
    """An obstacle's footprint [m, map frame] and height [m]."""

    name: str
    center: tuple[float, float]
    size: tuple[float, float]
    height: float


@dataclass(frozen=True)
class PadInfo:
    """A landing pad: marker id, centre [m, map frame], side [m]."""

    id: int
    center: tuple[float, float]
    side: float


@dataclass(frozen=True)
class FieldLayout:
    """Field size [m], obstacles, pads, the start pad, and each robot's points table
    (``{robot marker id: {pad id: points}}``: what the operator reads off a robot once its
    pictures arrive; the page shows the points of the robot found)."""

    size: tuple[float, float, float]
    obstacles: tuple[Box, ...] = ()
    pads: tuple[PadInfo, ...] = ()
    start_pad: int = 0
    points: tuple[tuple[int, tuple[tuple[int, int], ...]], ...] = ()
    name: str = ""

    @property
    def pad_ids(self) -> frozenset[int]:
        return frozenset(p.id for p in self.pads)

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "size": list(self.size),
            "obstacles": [{"name": b.name, "center": list(b.center), "size": list(b.size),
                           "height": b.height} for b in self.obstacles],
            "pads": [{"id": p.id, "center": list(p.center), "side": p.side}
                     for p in self.pads],
            "start_pad": self.start_pad,
            "points": {str(robot): {str(pad): pts for pad, pts in table}
                       for robot, table in self.points},
        }


__all__ = ["Box", "FieldLayout", "PadInfo"]
