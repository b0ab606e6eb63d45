"""The perception nodes' parameters: types, units and ranges here, values in
``config/aruco_scanner.yaml``."""

from __future__ import annotations

from dataclasses import dataclass, replace

from perception.aruco import MarkerKind, Preprocess, ScanMode, ScannerSettings
from perception.tracking import TrackerSettings
from runtime import param
from runtime.parameters import validate_parameters

MIN_SIDE_SAFETY = 0.6
"""A marker's side seen at ``max_range_m`` is at least this share of its pinhole size:
tilted by up to ~50 deg (cos), or seen obliquely at the frame's edge."""


@dataclass(frozen=True)
class ScannerParams:
    """Parameters of ``aruco_scanner``; values live in ``config/aruco_scanner.yaml``."""

    mode: ScanMode  # which markers are reported
    enabled: bool = param(description="scanning at start")
    pad_marker_size: float = param(unit="m", range=(0.0, 5.0), lo_open=True)
    robot_marker_size: float = param(unit="m", range=(0.0, 5.0), lo_open=True)
    camera_position: tuple[float, ...] = param(unit="m", range=(-2.0, 2.0),
                                               description="optical centre, body FLU")
    annotated_rate_hz: float = param(unit="Hz", range=(0.0, 30.0))
    robot_report_interval_s: float = param(unit="s", range=(0.0, 60.0))
    jpeg_quality: int = param(unit="%", range=(10, 100))
    health_rate_hz: float = param(unit="Hz", range=(0.1, 10.0))
    image_timeout_s: float = param(unit="s", range=(0.1, 10.0))
    low_light: bool = param(description="measured preprocessing passes, else OpenCV defaults")
    small_markers: bool = param(description="the SMALL pass for markers of a few px per module")
    full_frame_interval: int = param(unit="frames", range=(1, 100),
                                     description="while tracked markers are found again "
                                                 "where they were, search the whole frame "
                                                 "only every n-th frame")
    processing_s: float = param(unit="s", range=(0.0, 1.0),
                                description="a frame's scan on the vehicle's computer: "
                                            "markers are published this long after the image")
    max_range_m: float = param(unit="m", range=(0.0, 100.0),
                               description="farthest a marker is read; whole-frame searches "
                                           "skip smaller outlines (0: no floor)")
    height_margin_m: float = param(unit="m", range=(0.0, 100.0),
                                   description="while the odometry is fresh, the farthest "
                                               "marker is the vehicle's height plus this "
                                               "(at most max_range_m)")
    opencv_threads: int = param(range=(0, 64),
                                description="OpenCV's worker threads in this process "
                                            "(cv2.setNumThreads; 0: OpenCV's default, one "
                                            "per core)")

    def __post_init__(self) -> None:
        validate_parameters(self)
        if len(self.camera_position) != 3:
            raise ValueError(f"camera_position: expected [x, y, z], got {self.camera_position}")

    @property
    def side_lengths(self) -> dict[MarkerKind, float]:
        return {MarkerKind.PAD: self.pad_marker_size, MarkerKind.ROBOT: self.robot_marker_size}

    def tracker_settings(self) -> TrackerSettings:
        return TrackerSettings(full_frame_interval=self.full_frame_interval)

    def min_side_px(self, mode: ScanMode, focal_px: float, range_m: float | None = None
                    ) -> float:
        """The smallest side [px] a whole-frame search looks for: the smallest printed
        marker ``mode`` reports, ``range_m`` (``max_range_m`` when None, and never more)
        from a camera of focal length ``focal_px``, times :data:`MIN_SIDE_SAFETY` (0 when
        ``max_range_m`` is 0: no floor)."""
        if self.max_range_m <= 0.0:
            return 0.0
        farthest = self.max_range_m if range_m is None else min(range_m, self.max_range_m)
        sides = [side for kind, side in self.side_lengths.items()
                 if (kind is MarkerKind.PAD and mode is not ScanMode.ROBOTS)
                 or (kind is MarkerKind.ROBOT and mode is not ScanMode.PADS)]
        return MIN_SIDE_SAFETY * focal_px * min(sides) / max(farthest, 1e-3)

    def scanner_settings(self) -> ScannerSettings:
        """The detector's passes: ``low_light`` the measured ones (SMALL only with
        ``small_markers``), else OpenCV's defaults in one pass (the seed's baseline)."""
        settings = ScannerSettings() if self.low_light else ScannerSettings.opencv_defaults()
        if self.low_light and not self.small_markers:
            settings = replace(settings, passes=(Preprocess.NONE, Preprocess.STRETCH))
        return settings


__all__ = ["MIN_SIDE_SAFETY", "ScannerParams"]
