"""The map from depth: clouds into the map frame, a deterministic voxel map, map files.

Pure (numpy, open3d for files; no runtime imports). :class:`VoxelMap` keeps one point per
occupied voxel of side ``voxel_size`` on a grid anchored at a fixed ``origin`` (the map
frame's origin by default), so the same clouds in any order give the same map: each
voxel's point is its centre, and :meth:`VoxelMap.points` returns them sorted by voxel key.

Map frame (ENU), metres; camera points in the depth camera's FLU frame.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from flight_control.frames import quat_rotate
from navigation.errors import MapFileError

FloatArray = npt.NDArray[np.float64]
MAP_SUFFIXES = (".pcd", ".ply")
_KEY_BITS = 21  # bits per axis in a voxel key: +-2^20 voxels (52 km at 5 cm)
_KEY_OFFSET = 1 << (_KEY_BITS - 1)


def camera_to_map(points_camera: npt.ArrayLike, position: npt.ArrayLike,
                  orientation_wxyz: npt.ArrayLike, camera_offset: npt.ArrayLike, *,
                  min_range: float = 0.0, max_range: float = np.inf) -> FloatArray:
    """Camera FLU points [m] (camera axes = body axes, optical centre at ``camera_offset``
    in the body frame) to the map frame, given the body pose at the capture time. Points
    nearer than ``min_range`` or farther than ``max_range`` from the camera are dropped."""
    p = np.asarray(points_camera, dtype=np.float64).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    r = np.linalg.norm(p, axis=1)
    p = p[(r >= min_range) & (r <= max_range)]
    body = p + np.asarray(camera_offset, dtype=np.float64).reshape(3)
    q = np.asarray(orientation_wxyz, dtype=np.float64).reshape(4)
    return np.asarray(quat_rotate(q, body), dtype=np.float64).reshape(-1, 3) + np.asarray(
        position, dtype=np.float64).reshape(3)


class VoxelMap:
    """An accumulated, voxel-downsampled point map (see the module docstring)."""

    def __init__(self, voxel_size: float, origin: npt.ArrayLike = (0.0, 0.0, 0.0)) -> None:
        if not (np.isfinite(voxel_size) and voxel_size > 0.0):
            raise ValueError(f"voxel_size {voxel_size} m: must be > 0")
        self.voxel_size = float(voxel_size)
        self.origin = np.asarray(origin, dtype=np.float64).reshape(3)
        self._keys = np.empty(0, dtype=np.int64)
        self.version = 0  # bumped whenever a voxel is added

    def __len__(self) -> int:
        return len(self._keys)

    def _key(self, points: FloatArray) -> npt.NDArray[np.int64]:
        idx = np.floor((points - self.origin) / self.voxel_size).astype(np.int64) + _KEY_OFFSET
        idx = np.clip(idx, 0, (1 << _KEY_BITS) - 1)
        return (idx[:, 0] << (2 * _KEY_BITS)) | (idx[:, 1] << _KEY_BITS) | idx[:, 2]

    def add(self, points: npt.ArrayLike) -> int:
        """Add map-frame points; returns how many new voxels they filled."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        p = p[np.all(np.isfinite(p), axis=1)]
        if len(p) == 0:
            return 0
        keys = np.unique(self._key(p))
        # the map's keys stay sorted: find the new ones and insert them in place, O(map)
        # rather than re-sorting the whole map for every cloud (np.union1d)
        at = np.searchsorted(self._keys, keys)
        known = at < len(self._keys)
        known[known] = self._keys[at[known]] == keys[known]
        new = keys[~known]
        if len(new):
            self._keys = np.insert(self._keys, at[~known], new)
            self.version += 1
        return len(new)

    def points(self) -> FloatArray:
        """One point per voxel, its centre, sorted by voxel key: (N, 3) [m]."""
        mask = (1 << _KEY_BITS) - 1
        idx = np.stack([(self._keys >> (2 * _KEY_BITS)) & mask, (self._keys >> _KEY_BITS) & mask,
                        self._keys & mask], axis=1) - _KEY_OFFSET
        return self.origin + (idx.astype(np.float64) + 0.5) * self.voxel_size


def map_to_publish(clouds_fused: int, clouds_published: int | None, voxels: int) -> bool:
    """Whether there is a map to publish: a cloud fused since the last map was published
    (``clouds_published`` clouds had been fused then; None: no map published yet), or,
    before any cloud, a map loaded from a file (``voxels`` > 0). A fused cloud with nothing
    in range (the start pad facing open floor) is a map too: its points say where
    obstacles are, its stamp what the camera has seen, so a map of no voxel says the
    view is free space. Before any cloud and any file there is no map at all."""
    if clouds_published is None:
        return clouds_fused > 0 or voxels > 0
    return clouds_fused != clouds_published


def _check_suffix(path: Path) -> None:
    if path.suffix.lower() not in MAP_SUFFIXES:
        raise MapFileError(f"{path}: a map file must end in {' or '.join(MAP_SUFFIXES)}")


def save_map(path: Path | str, points: npt.ArrayLike) -> Path:
    """Write (N, 3) map points [m] as PCD or PLY (by the suffix), with open3d."""
    import open3d as o3d

    path = Path(path)
    _check_suffix(path)
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    path.parent.mkdir(parents=True, exist_ok=True)
    if not o3d.io.write_point_cloud(path, cloud, write_ascii=False):
        raise MapFileError(f"{path}: open3d could not write the map")
    return path


def load_map(path: Path | str) -> FloatArray:
    """Read a PCD or PLY map file: (N, 3) points [m]. Raises MapFileError when it is
    missing, of another format, or holds no point."""
    import open3d as o3d

    path = Path(path)
    _check_suffix(path)
    if not path.is_file():
        raise MapFileError(f"{path}: no such map file")
    cloud = o3d.io.read_point_cloud(path)
    points = np.asarray(cloud.points, dtype=np.float64)
    if len(points) == 0:
        raise MapFileError(f"{path}: no point in the map file (or not a readable "
                           f"{path.suffix[1:].upper()} file)")
    return points


__all__ = ["MAP_SUFFIXES", "VoxelMap", "camera_to_map", "load_map", "map_to_publish",
           "save_map"]
