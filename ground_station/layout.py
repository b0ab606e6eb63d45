"""The field as the operator page draws it: plain data, given by whoever knows the arena
(the app layer, from the arena file; or a launch). The ground station never reads the
simulator; this is what a contest's organisers hand the team before the run.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ground_station.errors import GroundStationError


class BadLayout(GroundStationError):
    """A field layout file that cannot be read."""


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


    @classmethod
    def from_json(cls, data: Any) -> FieldLayout:
        """The inverse of :meth:`to_json`; BadLayout names what is missing or wrong."""
        try:
            return cls(
                name=str(data.get("name", "")),
                size=tuple(float(v) for v in data["size"]),  # type: ignore[arg-type]
                obstacles=tuple(Box(str(b["name"]), (float(b["center"][0]), float(b["center"][1])),
                                    (float(b["size"][0]), float(b["size"][1])),
                                    float(b["height"])) for b in data.get("obstacles", [])),
                pads=tuple(PadInfo(int(p["id"]), (float(p["center"][0]), float(p["center"][1])),
                                   float(p["side"])) for p in data.get("pads", [])),
                start_pad=int(data.get("start_pad", 0)),
                points=tuple((int(robot), tuple((int(pad), int(pts))
                                                for pad, pts in table.items()))
                             for robot, table in data.get("points", {}).items()))
        except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
            raise BadLayout(f"not a field layout: {type(exc).__name__}: {exc}") from None


def load_layout(path: Path) -> FieldLayout:
    """A :class:`FieldLayout` from its JSON file (``OUT/field.json`` of a sim run)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise BadLayout(f"{path}: {exc}") from None
    try:
        return FieldLayout.from_json(data)
    except BadLayout as exc:
        raise BadLayout(f"{path}: {exc}") from None


__all__ = ["BadLayout", "Box", "FieldLayout", "PadInfo", "load_layout"]
