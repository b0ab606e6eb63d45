"""Rendering: the down camera reads pad and robot markers, depth points land on surfaces."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from sim.arena import ArenaSpec, Lighting, robot_pose
from sim.markers import detect_markers
from sim.mjcf import build_model
from sim.quadrotor import QuadrotorParams
from sim.render import CameraIntrinsics, DepthPointCloud, SceneRenderer, depth_to_points
from sim.scene import SceneIndex, place_quadrotor

PARAMS = QuadrotorParams()
HEIGHT = 1.5  # m, camera height above the pad for the marker checks


def test_down_camera_reads_every_pad_marker(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    index: SceneIndex,
    arena: ArenaSpec,
    renderer: SceneRenderer,
) -> None:
    intrinsics = CameraIntrinsics.from_camera(PARAMS.down_camera)
    for pad in arena.pads:
        camera_z = HEIGHT - PARAMS.down_camera.position[2]
        place_quadrotor(model, data, index, (*pad.center, camera_z + 0.01), yaw=0.0)
        image = renderer.down_image(data)
        assert image.shape == (480, 640, 3)
        markers = detect_markers(image)
        assert pad.id in markers, f"pad {pad.id}: saw {sorted(markers)}"
        corners = markers[pad.id]
        centre = corners.mean(axis=0)
        np.testing.assert_allclose(centre, (intrinsics.cx, intrinsics.cy), atol=1.5)
        side_px = np.linalg.norm(corners[1] - corners[0])
        assert side_px == pytest.approx(0.5 * intrinsics.fy / HEIGHT, rel=0.03)
        # Facing east, image up is east and image right is south: the marker's top-left
        # (north-west) corner shows at the bottom left.
        top_left = corners[0]
        assert top_left[0] < intrinsics.cx and top_left[1] > intrinsics.cy


def test_down_camera_reads_a_robot_marker(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    index: SceneIndex,
    arena: ArenaSpec,
    renderer: SceneRenderer,
) -> None:
    robot = arena.robots[1]
    (x, y), _ = robot_pose(robot, 0.0)
    place_quadrotor(model, data, index, (x, y, HEIGHT + 0.5), yaw=1.0)
    assert robot.marker_id in detect_markers(renderer.down_image(data))


def test_dark_preset_is_darker_and_pads_still_decode(arena: ArenaSpec) -> None:
    dark = build_model(arena, lighting=Lighting.DARK)
    index = SceneIndex.from_model(dark, arena)
    data = mujoco.MjData(dark)
    pad = arena.pads[4]
    place_quadrotor(dark, data, index, (*pad.center, HEIGHT), yaw=0.5)
    with SceneRenderer(dark) as renderer:
        image = renderer.down_image(data)
    assert image.mean() < 90
    assert pad.id in detect_markers(image)


def test_top_view_maps_the_field_north_up(
    data: mujoco.MjData, renderer: SceneRenderer, arena: ArenaSpec
) -> None:
    image = renderer.top_view(data).astype(int)
    sx, sy, _ = arena.field.size
    wall = arena.field.wall_thickness
    height, width, _ = image.shape
    assert (width, height) == (1000, round(1000 * (sy + 2 * wall) / (sx + 2 * wall)))
    scale = width / (sx + 2 * wall)  # px per metre

    def pixel(x: float, y: float) -> np.ndarray:
        return image[int((sy + wall - y) * scale), int((x + wall) * scale)]

    for pad in arena.pads:  # the light-blue rim of every pad, where the map says
        red, _, blue = pixel(pad.center[0] + 0.4, pad.center[1] - 0.4)
        assert blue > red + 40, f"pad {pad.id} not at its place in the top view"
    red, _, blue = pixel(*arena.obstacles[1].center)
    assert abs(red - blue) < 10, "obstacles are grey"


@pytest.mark.parametrize(
    ("position", "yaw", "face_distance", "half_width"),
    [
        # pillar obstacles[1]: 1.2 m wide, west face at x = 8.9
        ((6.9, 4.0, 1.5), 0.0, 8.9 - 6.9 - PARAMS.depth_camera.position[0], 0.6),
        # wall obstacles[2]: 4 m wide, south face at y = 10.3
        ((12.0, 8.0, 1.5), math.pi / 2, 10.3 - 8.0 - PARAMS.depth_camera.position[0], 2.0),
    ],
    ids=["pillar-east", "wall-north"],
)
def test_depth_points_land_on_the_obstacle_face(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    index: SceneIndex,
    renderer: SceneRenderer,
    position: tuple[float, float, float],
    yaw: float,
    face_distance: float,
    half_width: float,
) -> None:
    noise = 0.01
    place_quadrotor(model, data, index, position, yaw)
    cloud = DepthPointCloud(renderer, PARAMS.depth_camera, noise_std=noise, seed=3).points(data)
    assert cloud.dtype == np.float32 and cloud.shape[1] == 3
    intrinsics = CameraIntrinsics.from_camera(PARAMS.depth_camera)
    visible = min(half_width, face_distance * (intrinsics.width / 2.0) / intrinsics.fx)
    band = np.abs(cloud[:, 2]) < 0.5  # within 0.5 m of the camera height: face or beyond
    inner = cloud[band & (np.abs(cloud[:, 1]) < 0.9 * visible)]
    assert len(inner) > 1000
    np.testing.assert_allclose(inner[:, 0], face_distance, atol=5 * noise)
    assert inner[:, 0].mean() == pytest.approx(face_distance, abs=2e-3)
    assert inner[:, 0].std() == pytest.approx(noise, rel=0.15)
    on_face = cloud[band & (np.abs(cloud[:, 0] - face_distance) < 5 * noise)]
    assert np.abs(on_face[:, 1]).max() == pytest.approx(visible, abs=0.03), "face edges"


def test_point_noise_is_seeded(
    model: mujoco.MjModel, data: mujoco.MjData, index: SceneIndex, renderer: SceneRenderer
) -> None:
    place_quadrotor(model, data, index, (6.9, 4.0, 1.5))
    clouds = [
        DepthPointCloud(renderer, PARAMS.depth_camera, noise_std=0.02, seed=s).points(data)
        for s in (7, 7, 8)
    ]
    np.testing.assert_array_equal(clouds[0], clouds[1])
    assert not np.array_equal(clouds[0], clouds[2])


def test_unprojection_of_a_flat_wall() -> None:
    intrinsics = CameraIntrinsics.from_fovy(8, 6, math.radians(90.0))
    depth = np.full((6, 8), 2.0, dtype=np.float32)
    depth[0, 0] = 50.0  # beyond range: dropped
    points = depth_to_points(depth, intrinsics, min_range=0.1, max_range=10.0)
    assert len(points) == 47
    np.testing.assert_allclose(points[:, 0], 2.0)
    # 90 deg vertical fov: the image's top and bottom pixel centres sit just inside +-2 m
    assert points[:, 2].max() == pytest.approx(2.0 * 2.5 / 3.0)
    assert points[:, 1].max() == pytest.approx(2.0 * 3.5 / 3.0), "left of centre is +y"
