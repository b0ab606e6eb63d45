"""Marker tracking between frames: look where the markers just were before looking
everywhere (issue 21). Pure: numpy and the scanner, no runtime.

A marker moves little between two frames of the down camera (12 Hz): at 1 m/s and 1.5 m
up it moves ~30 px of a 640 px frame. :class:`RegionTracker` therefore searches each
marker of the last frame in a region around its last corners (the marker's bounding box
grown by ``margin`` of its side, at least ``margin_min_px``), with the scanner's own
passes on that region, ignoring outlines under ``shrink`` of its last side: the noise's
many small outlines are what a detector spends its time on, and a marker does not shrink
by half in a frame. A frame in which every marker of the last frame is found again is
done; the whole frame is still searched on every ``full_frame_interval``-th frame, so a
newcomer is reported at most ``full_frame_interval - 1`` frames late, and on any frame
where a tracked marker was lost (or none was tracked).

The region is the full image's pixels, so a marker read in its region is the marker the
whole frame gives, to the sub-pixel refinement's precision: adaptive thresholds are local
(the largest window is 53 px; the margin is wider) and the contrast stretch is the whole
frame's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from perception.aruco import (
    ArucoScanner,
    FloatArray,
    Image,
    Region,
    ScanMode,
    side_px,
    to_grey,
)

__all__ = ["RegionTracker", "TrackerSettings", "search_region"]


@dataclass(frozen=True)
class TrackerSettings:
    """How :class:`RegionTracker` searches (see the module docstring)."""

    full_frame_interval: int = 4  # frames; 1 searches every whole frame
    margin: float = 0.5  # of the marker's side, around its last bounding box
    margin_min_px: int = 40  # px, at least (> half the largest adaptive window, 53 px)
    shrink: float = 0.5  # of the marker's last side: shorter outlines are not searched

    def __post_init__(self) -> None:
        if self.full_frame_interval < 1:
            raise ValueError(f"TrackerSettings.full_frame_interval: "
                             f"{self.full_frame_interval} < 1 frame")
        if not 0.0 <= self.margin <= 10.0:
            raise ValueError(f"TrackerSettings.margin: {self.margin} not in [0, 10] sides")
        if not 0.0 < self.shrink <= 1.0:
            raise ValueError(f"TrackerSettings.shrink: {self.shrink} not in (0, 1]")
        if self.margin_min_px < 0:
            raise ValueError(f"TrackerSettings.margin_min_px: {self.margin_min_px} < 0")


def search_region(corners: npt.ArrayLike, shape: tuple[int, ...], margin: float,
                  margin_min_px: int) -> Region:
    """``(x0, y0, x1, y1)``, the pixels to search for a marker last seen at ``corners``
    (4, 2 px) in an image of ``shape`` (H, W[, C]): its bounding box grown by
    ``max(margin * side, margin_min_px)`` on each side, clipped to the image."""
    c = np.asarray(corners, dtype=np.float64).reshape(4, 2)
    grow = max(margin * side_px(c), float(margin_min_px))
    height, width = shape[:2]
    x0 = max(0, math.floor(float(c[:, 0].min()) - grow))
    y0 = max(0, math.floor(float(c[:, 1].min()) - grow))
    x1 = min(width, math.ceil(float(c[:, 0].max()) + grow) + 1)
    y1 = min(height, math.ceil(float(c[:, 1].max()) + grow) + 1)
    return x0, y0, x1, y1


class RegionTracker:
    """The scanner's :meth:`~perception.aruco.ArucoScanner.find`, frame after frame,
    searching first where the last frame's markers were (see the module docstring)."""

    def __init__(self, scanner: ArucoScanner, settings: TrackerSettings | None = None,
                 *, min_side_px: float = 0.0) -> None:
        self.scanner = scanner
        self.settings = settings or TrackerSettings()
        self.min_side_px = min_side_px
        """The smallest marker side [px] a whole-frame search looks for (see
        :meth:`ArucoScanner.find`); 0: the scanner's own floor."""
        self._last: dict[int, FloatArray] = {}
        self._since_full = 0  # frames since the last whole-frame search
        self.full_frames = 0  # whole-frame searches made (for health and benchmarks)
        self.tracked_frames = 0  # frames answered from the regions alone

    def reset(self) -> None:
        """Forget the markers seen (the next frame is searched whole)."""
        self._last = {}

    def find(self, image: npt.ArrayLike, mode: ScanMode = ScanMode.BOTH) -> dict[int, FloatArray]:
        """``{id: corners (4, 2) px}`` of the accepted markers in ``image``."""
        grey = to_grey(image)
        tracked = {i: c for i, c in self._last.items() if mode.accepts(i)}
        if tracked and self._since_full + 1 < self.settings.full_frame_interval:
            found = self._in_regions(grey, tracked, mode)
            if tracked.keys() <= found.keys():
                self._since_full += 1
                self.tracked_frames += 1
                self._last = found
                return found
        found = self.scanner.find(grey, mode, min_side_px=self.min_side_px)
        self._since_full = 0
        self.full_frames += 1
        self._last = found
        return found

    def _in_regions(self, grey: Image, tracked: dict[int, FloatArray],
                    mode: ScanMode) -> dict[int, FloatArray]:
        s = self.settings
        found: dict[int, FloatArray] = {}
        for marker_id, corners in tracked.items():
            if marker_id in found:  # read in an earlier marker's region
                continue
            region = search_region(corners, grey.shape, s.margin, s.margin_min_px)
            hits = self.scanner.find(grey, mode, wanted=(marker_id,), region=region,
                                     min_side_px=max(s.shrink * side_px(corners),
                                                     self.min_side_px))
            if marker_id not in hits:
                return found  # lost: the caller searches the whole frame
            for hit_id, hit in hits.items():
                found.setdefault(hit_id, hit)
        return found
