"""A printed marker lying on the arena floor, for recognition tests (seed 003 Table 1).

:func:`marker_board_scene` compiles the arena with one extra flat board: a ``size`` m
DICT_7X7_1000 marker on white paper (one-module quiet zone) at ``center`` on the floor,
lit by the arena's lighting preset. :func:`view_from_above` puts the quadrotor so that
its down camera looks at the board from ``distance`` m, with a given heading, tilt and
horizontal offset, ready to render with :class:`~sim.render.SceneRenderer`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from sim.arena import ArenaSpec, Lighting
from sim.markers import MARKER_MODULES, QUIET_ZONE_MODULES, QUIET_ZONE_RGB, encode_png, marker_tile
from sim.mjcf import build_spec
from sim.quadrotor import QuadrotorParams
from sim.scene import SceneIndex

BOARD_THICKNESS = 0.002  # m, paper on a thin board
BOARD_GEOM = "marker_board"


@dataclass
class MarkerBoardScene:
    arena: ArenaSpec
    quad: QuadrotorParams
    model: mujoco.MjModel
    data: mujoco.MjData
    index: SceneIndex
    center: tuple[float, float]


def marker_board_scene(arena: ArenaSpec, marker_id: int, size: float,
                       center: tuple[float, float], lighting: Lighting | None = None,
                       px_per_module: int = 16) -> MarkerBoardScene:
    """The arena with a ``size`` m marker ``marker_id`` on the floor at ``center``."""
    quad = QuadrotorParams()
    spec = build_spec(arena, quad, lighting)
    tile_size = size * (MARKER_MODULES + 2 * QUIET_ZONE_MODULES) / MARKER_MODULES
    png = encode_png(marker_tile(marker_id, tile_size, size, QUIET_ZONE_RGB, px_per_module))
    spec.assets = {**spec.assets, f"{BOARD_GEOM}.png": png}
    spec.add_texture(name=BOARD_GEOM, type=mujoco.mjtTexture.mjTEXTURE_2D,
                     file=f"{BOARD_GEOM}.png")
    material = spec.add_material(name=BOARD_GEOM)
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = BOARD_GEOM
    spec.worldbody.add_geom(name=BOARD_GEOM, type=mujoco.mjtGeom.mjGEOM_BOX,
                            pos=[center[0], center[1], BOARD_THICKNESS / 2.0],
                            size=[tile_size / 2.0, tile_size / 2.0, BOARD_THICKNESS / 2.0],
                            material=BOARD_GEOM, contype=0, conaffinity=0)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return MarkerBoardScene(arena, quad, model, data, SceneIndex.from_model(model, arena),
                            center)


def view_from_above(scene: MarkerBoardScene, distance: float, *, yaw: float = 0.0,
                    roll: float = 0.0, pitch: float = 0.0,
                    offset: tuple[float, float] = (0.0, 0.0)) -> None:
    """Pose the quadrotor so the down camera is ``distance`` m above the board, shifted by
    ``offset`` [m] and turned by ``yaw``, ``roll``, ``pitch`` [rad] (ZYX, FLU)."""
    camera_z = scene.quad.down_camera.position[2]
    x, y = scene.center[0] + offset[0], scene.center[1] + offset[1]
    z = BOARD_THICKNESS + distance - camera_z
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    q = np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                  cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])
    adr = scene.index.qpos_adr
    scene.data.qpos[adr:adr + 3] = (x, y, z)
    scene.data.qpos[adr + 3:adr + 7] = q
    scene.data.qvel[scene.index.qvel_adr:scene.index.qvel_adr + 6] = 0.0
    mujoco.mj_forward(scene.model, scene.data)


__all__ = ["BOARD_GEOM", "MarkerBoardScene", "marker_board_scene", "view_from_above"]
