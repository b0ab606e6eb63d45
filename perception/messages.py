"""The scanner's messages: a measured marker as a MarkerDetection, an image as a JPEG
CompressedImage. Pure conversion (OpenCV, numpy), no runtime."""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np

import interfaces
from perception.aruco import DICTIONARY_NAME, Marker, MarkerKind

MARKER: Any = interfaces.get_message("quadmission_interfaces/msg/MarkerDetection")
_KIND_CODE = {MarkerKind.PAD: MARKER.KIND_PAD, MarkerKind.ROBOT: MARKER.KIND_ROBOT,
              MarkerKind.OTHER: MARKER.KIND_OTHER}


def _quat_wxyz_from_matrix(r: np.ndarray) -> tuple[float, float, float, float]:
    w = math.sqrt(max(0.0, 1.0 + r[0, 0] + r[1, 1] + r[2, 2])) / 2.0
    x = math.copysign(math.sqrt(max(0.0, 1.0 + r[0, 0] - r[1, 1] - r[2, 2])) / 2.0,
                      r[2, 1] - r[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - r[0, 0] + r[1, 1] - r[2, 2])) / 2.0,
                      r[0, 2] - r[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - r[0, 0] - r[1, 1] + r[2, 2])) / 2.0,
                      r[1, 0] - r[0, 1])
    return w, x, y, z


def detection_msg(marker: Marker, header: Any) -> Any:
    """A MarkerDetection of one measured marker, with the image's header."""
    w, x, y, z = _quat_wxyz_from_matrix(marker.rotation_cam)
    p = marker.position_cam
    return interfaces.new(
        MARKER, header=header, id=marker.id, kind=_KIND_CODE[marker.kind],
        dictionary=DICTIONARY_NAME,
        corners_px=marker.corners_px.reshape(-1).astype(np.float32),
        center_px=marker.center_px.astype(np.float32),
        error_px=marker.error_px.astype(np.float32),
        offset_x=float(marker.offset_body[0]), offset_y=float(marker.offset_body[1]),
        height=float(marker.height), side_length=float(marker.side_length),
        pose=interfaces.new("geometry_msgs/msg/Pose",
                            position=interfaces.point(*p),
                            orientation=interfaces.new("geometry_msgs/msg/Quaternion", w=w,
                                                       x=x, y=y, z=z)),
        reprojection_error_px=float(marker.reprojection_error_px))


def jpeg_msg(rgb: np.ndarray, header: Any, quality: int) -> Any:
    """A sensor_msgs/CompressedImage (JPEG) of an RGB image."""
    ok, buffer = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR),
                              [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError(f"cannot encode a {rgb.shape} image as JPEG")
    return interfaces.new("sensor_msgs/msg/CompressedImage", header=header, format="jpeg",
                          data=np.frombuffer(buffer.tobytes(), dtype=np.uint8))


__all__ = ["detection_msg", "jpeg_msg"]
