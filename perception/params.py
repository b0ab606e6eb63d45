"""The perception nodes' parameters: types, units and ranges here, values in
``config/aruco_scanner.yaml``."""

from __future__ import annotations

from dataclasses import dataclass, replace

from perception.aruco import MarkerKind, Preprocess, ScanMode, ScannerSettings
from runtime import param
from runtime.parameters import validate_parameters


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

    def __post_init__(self) -> None:
        validate_parameters(self)
        if len(self.camera_position) != 3:
            raise ValueError(f"camera_position: expected [x, y, z], got {self.camera_position}")

    @property
    def side_lengths(self) -> dict[MarkerKind, float]:
        return {MarkerKind.PAD: self.pad_marker_size, MarkerKind.ROBOT: self.robot_marker_size}

    def scanner_settings(self) -> ScannerSettings:
        """The detector's passes: ``low_light`` the measured ones (SMALL only with
        ``small_markers``), else OpenCV's defaults in one pass (the seed's baseline)."""
        settings = ScannerSettings() if self.low_light else ScannerSettings.opencv_defaults()
        if self.low_light and not self.small_markers:
            settings = replace(settings, passes=(Preprocess.NONE, Preprocess.STRETCH))
        return settings


__all__ = ["ScannerParams"]
