"""Typed parameters of the ground-station nodes (values in config/<node>.yaml)."""

from __future__ import annotations

from dataclasses import dataclass

from runtime import param


@dataclass(frozen=True)
class RecorderParams:
    folder: str = param(description="the bag folder, when the node is started from a launch "
                        "file ('' = given by the app: --record writes OUT/bag)")
    include: str = param(description="topics to record: a regular expression (fullmatch)")
    exclude: str = param(description="topics not to record: a regular expression, or ''")
    discovery_period_s: float = param(unit="s", range=(0.01, 10.0),
                                      description="how often new topics are looked for")
    flush_period_s: float = param(unit="s", range=(0.05, 1.0),
                                  description="host time between sealed, flushed chunks")


@dataclass(frozen=True)
class FoxgloveBridgeParams:
    host: str = param(description="address the WebSocket server binds to")
    port: int = param(range=(0, 65535), description="TCP port; 0 picks a free one")
    include: str = param(description="topics to serve: a regular expression (fullmatch)")
    exclude: str = param(description="topics not to serve: a regular expression, or ''")
    discovery_period_s: float = param(unit="s", range=(0.01, 10.0),
                                      description="how often new topics are looked for")


@dataclass(frozen=True)
class GroundStationParams:
    camera_period_s: float = param(unit="s", range=(0.05, 10.0),
                                   description="at most one down-camera JPEG per period")
    camera_width_px: int = param(range=(32, 1920), description="width the JPEG is scaled to")
    jpeg_quality: int = param(range=(10, 100), description="JPEG quality")
    flown_path_spacing_m: float = param(unit="m", range=(0.01, 5.0),
                                        description="distance between kept flown-path points")
    flown_path_max_points: int = param(range=(10, 100000),
                                       description="flown-path points kept (oldest dropped)")
    map_max_points: int = param(range=(0, 200000),
                                description="voxel-map points kept for the page")
    command_period_s: float = param(unit="s", range=(0.001, 1.0),
                                    description="how often queued operator commands are sent")
    host: str = param(description="address the page binds to (loopback unless changed)")
    port: int = param(range=(0, 65535), description="the page's TCP port; 0 picks a free one")
    layout_file: str = param(description="the field as JSON (FieldLayout), or '' for none")


__all__ = ["FoxgloveBridgeParams", "GroundStationParams", "RecorderParams"]
