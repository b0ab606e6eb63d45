"""sensor_msgs/PointCloud2 <-> (N, 3) float arrays (packed float32 x, y, z)."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

import interfaces

FLOAT32 = 7  # sensor_msgs/PointField.FLOAT32


def cloud_msg(points: npt.ArrayLike, stamp: Any, frame_id: str) -> Any:
    """An unorganised PointCloud2 with float32 x, y, z; ``stamp`` a builtin Time message."""
    pts = np.ascontiguousarray(np.asarray(points, dtype=np.float32).reshape(-1, 3))
    fields = [interfaces.new("sensor_msgs/msg/PointField", name=n, offset=4 * i,
                             datatype=FLOAT32, count=1) for i, n in enumerate("xyz")]
    return interfaces.new(
        "sensor_msgs/msg/PointCloud2",
        header=interfaces.new("std_msgs/msg/Header", stamp=stamp, frame_id=frame_id),
        height=1, width=len(pts), fields=fields, is_bigendian=False, point_step=12,
        row_step=12 * len(pts), data=pts.view(np.uint8).reshape(-1), is_dense=True)


def cloud_points(msg: Any) -> npt.NDArray[np.float64]:
    """The (N, 3) points of a PointCloud2 whose first fields are float32 x, y, z."""
    fields = {f.name: f for f in msg.fields}
    if any(n not in fields or int(fields[n].datatype) != FLOAT32 for n in "xyz"):
        raise ValueError(f"expected float32 x, y, z fields, got {[f.name for f in msg.fields]}")
    step = int(msg.point_step)
    n = int(msg.width) * int(msg.height)
    raw = np.asarray(msg.data, dtype=np.uint8).tobytes()
    rows = np.frombuffer(raw, dtype=np.uint8)[: n * step].reshape(n, step)
    out = np.empty((n, 3), dtype=np.float64)
    for i, name in enumerate("xyz"):
        off = int(fields[name].offset)
        out[:, i] = rows[:, off:off + 4].copy().view(np.float32).reshape(-1)
    return out


__all__ = ["cloud_msg", "cloud_points"]
