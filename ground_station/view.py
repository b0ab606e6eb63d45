"""What the operator page shows, folded from the topics: pure data, no runtime.

:class:`OperatorView` keeps the latest vehicle pose, the flown path (thinned), the
planned path, the FCU and link health, the mission state and events, the voxel map's
points, the latest camera JPEG and the robot pictures. ``snapshot()`` is the JSON the
page polls; ``revision`` grows with every change, so the page (and a test) sees that
the state is live. Thread-safe: the node writes from the executor's thread, the web
server reads from its own.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from ground_station.layout import FieldLayout

MAX_EVENTS = 50


@dataclass(frozen=True)
class Pose2:
    x: float
    y: float
    z: float
    yaw: float  # rad, ENU (0 = +x, counter-clockwise)


@dataclass(frozen=True)
class RobotPicture:
    marker_id: int
    x: float
    y: float
    sightings: int
    jpeg: bytes | None


@dataclass
class OperatorView:
    """The ground station's picture of the mission."""

    layout: FieldLayout | None = None
    phase_names: dict[int, str] = field(default_factory=dict)  # MissionState PHASE_* values
    path_spacing_m: float = 0.05
    path_max_points: int = 5000
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    revision: int = 0
    t_s: float = 0.0
    pose: Pose2 | None = None
    flown: deque[tuple[float, float]] = field(default_factory=deque)
    planned: list[tuple[float, float]] = field(default_factory=list)
    planned_source: str = ""
    fcu: dict[str, Any] = field(default_factory=dict)
    timesync: dict[str, Any] = field(default_factory=dict)
    health: dict[str, Any] = field(default_factory=dict)
    mission: dict[str, Any] = field(default_factory=dict)
    events: deque[dict[str, Any]] = field(default_factory=lambda: deque(maxlen=MAX_EVENTS))
    proposal: list[int] = field(default_factory=list)
    map_points: list[tuple[float, float, float]] = field(default_factory=list)
    camera_jpeg: bytes | None = None
    camera_revision: int = 0
    robots: dict[int, RobotPicture] = field(default_factory=dict)
    commands: deque[dict[str, Any]] = field(default_factory=lambda: deque(maxlen=MAX_EVENTS))

    def __post_init__(self) -> None:
        self.flown = deque(maxlen=self.path_max_points)

    def _changed(self, t_s: float) -> None:
        self.revision += 1
        self.t_s = max(self.t_s, t_s)

    def on_pose(self, t_s: float, pose: Pose2, flown: bool = True) -> None:
        """The latest pose; also a flown-path point unless ``flown`` is False (the FCU
        says its position is not valid yet)."""
        with self._lock:
            self.pose = pose
            last = self.flown[-1] if self.flown else None
            if not flown:
                pass
            elif last is None or math.dist(last, (pose.x, pose.y)) >= self.path_spacing_m:
                self.flown.append((pose.x, pose.y))
            self._changed(t_s)

    def on_planned_path(self, t_s: float, points: list[tuple[float, float]],
                        source: str) -> None:
        with self._lock:
            self.planned = list(points)
            self.planned_source = source
            self._changed(t_s)

    def on_fcu(self, t_s: float, status: dict[str, Any]) -> None:
        with self._lock:
            self.fcu = dict(status)
            self._changed(t_s)

    def on_timesync(self, t_s: float, status: dict[str, Any]) -> None:
        with self._lock:
            self.timesync = dict(status)
            self._changed(t_s)

    def on_health(self, t_s: float, report: dict[str, Any]) -> None:
        with self._lock:
            self.health = dict(report)
            self._changed(t_s)

    def on_mission_state(self, t_s: float, state: dict[str, Any]) -> None:
        with self._lock:
            self.mission = dict(state)
            self._changed(t_s)

    def on_event(self, t_s: float, event: dict[str, Any]) -> None:
        with self._lock:
            self.events.append(dict(event))
            self._changed(t_s)

    def on_proposal(self, t_s: float, pads: list[int]) -> None:
        with self._lock:
            self.proposal = list(pads)
            self._changed(t_s)

    def on_map(self, t_s: float, points: list[tuple[float, float, float]]) -> None:
        with self._lock:
            self.map_points = points
            self._changed(t_s)

    def on_camera(self, t_s: float, jpeg: bytes) -> None:
        with self._lock:
            self.camera_jpeg = jpeg
            self.camera_revision += 1
            self._changed(t_s)

    def on_robot(self, t_s: float, picture: RobotPicture) -> None:
        with self._lock:
            old = self.robots.get(picture.marker_id)
            if picture.jpeg is None and old is not None:
                picture = RobotPicture(picture.marker_id, picture.x, picture.y,
                                       picture.sightings, old.jpeg)
            self.robots[picture.marker_id] = picture
            self._changed(t_s)

    def on_command(self, record: dict[str, Any]) -> None:
        with self._lock:
            self.commands.append(dict(record))
            self.revision += 1

    def camera(self) -> bytes | None:
        with self._lock:
            return self.camera_jpeg

    def robot_jpeg(self, marker_id: int) -> bytes | None:
        with self._lock:
            robot = self.robots.get(marker_id)
            return robot.jpeg if robot else None

    def snapshot(self) -> dict[str, Any]:
        """Everything the page draws, as JSON-ready data."""
        with self._lock:
            pose = self.pose
            return {
                "revision": self.revision,
                "t_s": round(self.t_s, 3),
                "layout": self.layout.to_json() if self.layout else None,
                "phases": {str(k): v for k, v in sorted(self.phase_names.items())},
                "pose": None if pose is None else {
                    "x": round(pose.x, 3), "y": round(pose.y, 3), "z": round(pose.z, 3),
                    "yaw": round(pose.yaw, 4)},
                "flown": [[round(x, 3), round(y, 3)] for x, y in self.flown],
                "planned": [[round(x, 3), round(y, 3)] for x, y in self.planned],
                "planned_source": self.planned_source,
                "fcu": self.fcu,
                "timesync": self.timesync,
                "health": self.health,
                "mission": self.mission,
                "events": list(self.events),
                "proposal": self.proposal,
                "map": [[round(x, 2), round(y, 2), round(z, 2)] for x, y, z in self.map_points],
                "camera_revision": self.camera_revision,
                "robots": [{"marker_id": r.marker_id, "x": round(r.x, 3), "y": round(r.y, 3),
                            "sightings": r.sightings, "picture": r.jpeg is not None}
                           for r in sorted(self.robots.values(), key=lambda r: r.marker_id)],
                "commands": list(self.commands),
            }


__all__ = ["MAX_EVENTS", "OperatorView", "Pose2", "RobotPicture"]
