"""The map from depth (navigation/mapping.py): frames, deterministic voxels, map files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navigation.errors import MapFileError
from navigation.mapping import VoxelMap, camera_to_map, load_map, map_to_publish, save_map


def test_camera_points_land_in_the_map_frame_with_the_pose() -> None:
    yaw = math.pi / 2  # facing north
    q = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
    pts = camera_to_map([[2.0, 0.0, 0.0], [1.0, 0.5, -0.5]], (1.0, 2.0, 1.5), q, (0.12, 0.0, 0.0))
    # forward 2 m (+0.12 m mount) is north; left is west; down is down
    assert pts[0] == pytest.approx([1.0, 4.12, 1.5])
    assert pts[1] == pytest.approx([0.5, 3.12, 1.0])


def test_range_limits_drop_points() -> None:
    pts = camera_to_map([[0.05, 0, 0], [3.0, 0, 0], [9.0, 0, 0]], (0, 0, 0), (1, 0, 0, 0),
                        (0, 0, 0), min_range=0.1, max_range=6.0)
    assert pts[:, 0].tolist() == [3.0]


def test_a_fused_cloud_is_a_map_even_with_nothing_in_range() -> None:
    """A view of open floor adds no voxel, yet it is a map: free space, seen."""
    assert not map_to_publish(0, None, 0)  # no cloud, no file: no map yet
    assert map_to_publish(1, None, 0)  # a cloud with nothing in range: an empty map
    assert map_to_publish(0, None, 120)  # a map file, before any cloud
    assert not map_to_publish(0, 0, 120)  # the file's map, already published
    assert not map_to_publish(3, 3, 0)  # nothing fused since the last map
    assert map_to_publish(4, 3, 0)  # another empty view: a newer stamp


def test_voxel_map_is_deterministic_and_order_independent() -> None:
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 5, (500, 3)), rng.uniform(0, 5, (500, 3))
    m1, m2 = VoxelMap(0.1), VoxelMap(0.1)
    m1.add(a)
    m1.add(b)
    m2.add(b)
    m2.add(np.vstack([a, a]))
    assert np.array_equal(m1.points(), m2.points())
    keys = np.floor(np.vstack([a, b]) / 0.1)
    assert len(m1) == len(np.unique(keys, axis=0))
    # each map point is the centre of a voxel holding an input point
    assert np.allclose((m1.points() / 0.1) % 1.0, 0.5)
    before = m1.version
    assert m1.add(a) == 0 and m1.version == before  # nothing new: no new version


@pytest.mark.parametrize("suffix", [".pcd", ".ply"])
def test_maps_round_trip_through_files(tmp_path, suffix: str) -> None:  # type: ignore[no-untyped-def]
    m = VoxelMap(0.05)
    m.add(np.random.default_rng(1).uniform(-2, 2, (300, 3)))
    path = save_map(tmp_path / f"map{suffix}", m.points())
    back = load_map(path)
    assert np.allclose(back, m.points(), atol=1e-6)


def test_map_file_errors_name_the_problem(tmp_path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(MapFileError, match="no such map file"):
        load_map(tmp_path / "missing.pcd")
    with pytest.raises(MapFileError, match=r"\.pcd or \.ply"):
        save_map(tmp_path / "map.txt", np.zeros((1, 3)))
    with pytest.raises(ValueError, match="voxel_size"):
        VoxelMap(0.0)
