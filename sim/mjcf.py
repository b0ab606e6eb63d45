"""MuJoCo model builder: contest arena and quadrotor, assembled with ``mujoco.MjSpec``.

World frame: ENU ``map`` (x east, y north, z up), origin at the field's south-west floor
corner (see :mod:`sim.arena`). The quadrotor body frame is FLU (see :mod:`sim.quadrotor`).

Thrust: each rotor is a MuJoCo ``general`` actuator with a *site* transmission at the rotor
hub and gear ``(0, 0, 1, 0, 0, -spin * km/kf)``, so ``ctrl = T`` newtons pushes along body
+z at the hub and applies the rotor's reaction yaw torque. The actuator has no dynamics of
its own: the world loop runs :class:`sim.quadrotor.MotorModel` (commanded -> actual thrust,
30 ms lag) and writes the actual thrust to ``data.ctrl`` (:func:`sim.scene.set_motor_thrusts`).
Actuators rather than ``xfrc_applied`` keep the rotor forces visible in
``data.actuator_force`` and leave ``xfrc_applied`` free for disturbances (wind, ground
effect).

Collisions: arena geoms (floor, walls, obstacles, pads, robots) collide only with the drone,
never with each other. The drone's own geoms are in geom group :data:`QUAD_GEOM_GROUP`, which
the onboard cameras do not render (a sensor mask: the drone never sees its own props).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import mujoco

from sim.arena import (
    PAD_SIZE,
    PAD_THICKNESS,
    ROBOT_SIZE,
    ArenaSpec,
    Lighting,
    robot_pose,
)
from sim.markers import DEFAULT_PX_PER_MODULE, encode_png, pad_texture, robot_texture
from sim.quadrotor import GRAVITY, CameraParams, QuadrotorParams, Spin, rotors

Vec3 = tuple[float, float, float]
Rgba = tuple[float, float, float, float]

DEFAULT_TIMESTEP_US = 2000  # physics step, 500 Hz
ZNEAR = 0.02  # m, near clipping plane of every camera
ZFAR = 100.0  # m, far clipping plane of every camera
TOP_VIEW_WIDTH = 1000  # px, width of the top-down arena view; height follows the field

# Names in the compiled model (the contract for sim.scene and sim.render).
QUAD_BODY = "quad"
QUAD_JOINT = "quad_root"
IMU_SITE = "imu"
ACCEL_SENSOR = "imu_accel"
GYRO_SENSOR = "imu_gyro"
DOWN_CAMERA = "down_camera"
DEPTH_CAMERA = "depth_camera"
TOP_CAMERA = "arena_top"

QUAD_GEOM_GROUP = 2
_ARENA_CONTYPE, _ARENA_CONAFFINITY = 1, 2
_QUAD_CONTYPE, _QUAD_CONAFFINITY = 2, 1


def motor_name(index: int) -> str:
    """Actuator name of rotor ``index`` (PX4 quad-X order)."""
    return f"motor_{index}"


def rotor_site_name(index: int) -> str:
    """Site name of rotor ``index``'s hub."""
    return f"rotor_{index}"


def pad_geom_name(pad_id: int) -> str:
    """Geom name of landing pad ``pad_id``."""
    return f"pad_{pad_id}"


def robot_body_name(marker_id: int) -> str:
    """Mocap body name of the ground robot carrying ``marker_id``."""
    return f"robot_{marker_id}"


def obstacle_geom_name(index: int) -> str:
    """Geom name of ``arena.obstacles[index]``."""
    return f"obstacle_{index}"


@dataclass(frozen=True)
class LightingPreset:
    """Light intensities (0-1, grey) of a :class:`~sim.arena.Lighting` preset."""

    headlight_ambient: float
    headlight_diffuse: float
    overhead_diffuse: float
    shadows: bool = False  # shadows cost ~5x render time with software GL


LIGHTING_PRESETS: Mapping[Lighting, LightingPreset] = MappingProxyType(
    {
        Lighting.LIGHT: LightingPreset(
            headlight_ambient=0.35, headlight_diffuse=0.35, overhead_diffuse=0.6
        ),
        Lighting.DARK: LightingPreset(
            headlight_ambient=0.06, headlight_diffuse=0.06, overhead_diffuse=0.12
        ),
    }
)


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0)]


def _collide_with_drone(geom: mujoco.MjsGeom) -> None:
    geom.contype = _ARENA_CONTYPE
    geom.conaffinity = _ARENA_CONAFFINITY


class ContestArena:
    """Keyword-configured builder that adds a contest field to an ``MjSpec``.

    Adds the floor, four walls, box obstacles, textured landing pads, ground robots as
    mocap bodies (posed by :func:`sim.scene.set_robot_poses`), lights and the top-down
    orthographic camera :data:`TOP_CAMERA`.
    """

    def __init__(
        self,
        arena: ArenaSpec,
        *,
        lighting: Lighting | None = None,
        px_per_module: int = DEFAULT_PX_PER_MODULE,
        floor_rgb: tuple[Vec3, Vec3] = ((0.42, 0.42, 0.44), (0.38, 0.38, 0.40)),
        wall_rgba: Rgba = (0.85, 0.85, 0.82, 1.0),
        robot_rgba: Rgba = (0.9, 0.45, 0.1, 1.0),
    ) -> None:
        self.arena = arena
        self.lighting = arena.lighting if lighting is None else lighting
        self.px_per_module = px_per_module
        self.floor_rgb = floor_rgb
        self.wall_rgba = wall_rgba
        self.robot_rgba = robot_rgba

    def build(self, spec: mujoco.MjSpec) -> None:
        """Add the arena to ``spec`` (textures go into ``spec.assets`` as PNG files)."""
        self._add_floor_and_walls(spec)
        self._add_obstacles(spec)
        self._add_pads(spec)
        self._add_robots(spec)
        self._add_lights(spec)
        self._add_top_camera(spec)

    def _textured_material(self, spec: mujoco.MjSpec, name: str, png: bytes) -> str:
        filename = f"{name}.png"
        spec.assets = {**spec.assets, filename: png}
        spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, file=filename)
        material = spec.add_material(name=name)
        material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name
        return name

    def _add_floor_and_walls(self, spec: mujoco.MjSpec) -> None:
        sx, sy, sz = self.arena.field.size
        t = self.arena.field.wall_thickness
        rgb1, rgb2 = self.floor_rgb
        spec.add_texture(
            name="floor",
            type=mujoco.mjtTexture.mjTEXTURE_2D,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
            width=256,
            height=256,
            rgb1=list(rgb1),
            rgb2=list(rgb2),
        )
        floor = spec.add_material(name="floor", texrepeat=[1.0, 1.0], texuniform=True)
        floor.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "floor"
        world = spec.worldbody
        _collide_with_drone(
            world.add_geom(
                name="floor",
                type=mujoco.mjtGeom.mjGEOM_PLANE,
                pos=[sx / 2.0, sy / 2.0, 0.0],
                size=[sx / 2.0 + t, sy / 2.0 + t, 0.1],
                material="floor",
            )
        )
        walls = {
            "wall_west": ([-t / 2.0, sy / 2.0], [t / 2.0, sy / 2.0 + t]),
            "wall_east": ([sx + t / 2.0, sy / 2.0], [t / 2.0, sy / 2.0 + t]),
            "wall_south": ([sx / 2.0, -t / 2.0], [sx / 2.0, t / 2.0]),
            "wall_north": ([sx / 2.0, sy + t / 2.0], [sx / 2.0, t / 2.0]),
        }
        for name, (center, half) in walls.items():
            _collide_with_drone(
                world.add_geom(
                    name=name,
                    type=mujoco.mjtGeom.mjGEOM_BOX,
                    pos=[*center, sz / 2.0],
                    size=[*half, sz / 2.0],
                    rgba=list(self.wall_rgba),
                )
            )

    def _add_obstacles(self, spec: mujoco.MjSpec) -> None:
        ceiling = self.arena.field.size[2]
        for i, box in enumerate(self.arena.obstacles):
            grey = 0.75 - 0.4 * box.height / ceiling  # taller is darker, as on the contest map
            _collide_with_drone(
                spec.worldbody.add_geom(
                    name=obstacle_geom_name(i),
                    type=mujoco.mjtGeom.mjGEOM_BOX,
                    pos=[box.center[0], box.center[1], box.height / 2.0],
                    size=[box.size[0] / 2.0, box.size[1] / 2.0, box.height / 2.0],
                    rgba=[grey, grey, grey, 1.0],
                )
            )

    def _add_pads(self, spec: mujoco.MjSpec) -> None:
        for pad in self.arena.pads:
            name = pad_geom_name(pad.id)
            png = encode_png(pad_texture(pad.id, self.px_per_module))
            _collide_with_drone(
                spec.worldbody.add_geom(
                    name=name,
                    type=mujoco.mjtGeom.mjGEOM_BOX,
                    pos=[pad.center[0], pad.center[1], PAD_THICKNESS / 2.0],
                    size=[PAD_SIZE / 2.0, PAD_SIZE / 2.0, PAD_THICKNESS / 2.0],
                    material=self._textured_material(spec, name, png),
                )
            )

    def _add_robots(self, spec: mujoco.MjSpec) -> None:
        lx, ly, lz = ROBOT_SIZE
        plate = 0.005  # m, marker plate on the robot's top
        clearance = 0.03  # m, body above the floor (wheels)
        for robot in self.arena.robots:
            name = robot_body_name(robot.marker_id)
            (x, y), yaw = robot_pose(robot, 0.0)
            body = spec.worldbody.add_body(name=name, pos=[x, y, 0.0], quat=_yaw_quat(yaw))
            body.mocap = True
            body_height = lz - plate - clearance
            _collide_with_drone(
                body.add_geom(
                    name=f"{name}_body",
                    type=mujoco.mjtGeom.mjGEOM_BOX,
                    pos=[0.0, 0.0, clearance + body_height / 2.0],
                    size=[lx / 2.0, ly / 2.0, body_height / 2.0],
                    rgba=list(self.robot_rgba),
                )
            )
            png = encode_png(robot_texture(robot.marker_id, self.px_per_module))
            _collide_with_drone(
                body.add_geom(
                    name=f"{name}_marker",
                    type=mujoco.mjtGeom.mjGEOM_BOX,
                    pos=[0.0, 0.0, lz - plate / 2.0],
                    size=[lx / 2.0, ly / 2.0, plate / 2.0],
                    material=self._textured_material(spec, name, png),
                )
            )

    def _add_lights(self, spec: mujoco.MjSpec) -> None:
        preset = LIGHTING_PRESETS[self.lighting]
        spec.visual.headlight.ambient = [preset.headlight_ambient] * 3
        spec.visual.headlight.diffuse = [preset.headlight_diffuse] * 3
        spec.visual.headlight.specular = [0.05] * 3
        sx, sy, sz = self.arena.field.size
        spec.worldbody.add_light(
            name="overhead",
            type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
            pos=[sx / 2.0, sy / 2.0, sz],
            dir=[0.2, 0.1, -1.0],
            diffuse=[preset.overhead_diffuse] * 3,
            specular=[0.1] * 3,
            castshadow=preset.shadows,
        )

    def _add_top_camera(self, spec: mujoco.MjSpec) -> None:
        sx, sy, sz = self.arena.field.size
        width, height = top_view_size(self.arena)
        spec.worldbody.add_camera(
            name=TOP_CAMERA,
            pos=[sx / 2.0, sy / 2.0, sz + 10.0],
            xyaxes=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            proj=mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC,
            fovy=sy + 2.0 * self.arena.field.wall_thickness,
            resolution=[width, height],
        )


def top_view_size(arena: ArenaSpec) -> tuple[int, int]:
    """Pixel size of the top-down view: :data:`TOP_VIEW_WIDTH` wide, walls included."""
    sx, sy, _ = arena.field.size
    margin = 2.0 * arena.field.wall_thickness
    return TOP_VIEW_WIDTH, round(TOP_VIEW_WIDTH * (sy + margin) / (sx + margin))


def _add_camera(body: mujoco.MjsBody, name: str, params: CameraParams, xyaxes: list[float]) -> None:
    body.add_camera(
        name=name,
        pos=list(params.position),
        xyaxes=xyaxes,
        fovy=params.fovy_deg,
        resolution=[params.width, params.height],
    )


def add_quadrotor(
    spec: mujoco.MjSpec, params: QuadrotorParams, position: Vec3, yaw: float = 0.0
) -> None:
    """Add the quadrotor (free body, rotors, cameras, IMU) at ``position`` [m], heading ``yaw``.

    Inertia is explicit (``params.mass``, ``params.inertia`` at the body origin); geoms only
    collide and render. Cameras: :data:`DOWN_CAMERA` looks along body -z with image up =
    body forward; :data:`DEPTH_CAMERA` looks along body +x with image up = body up.
    """
    body = spec.worldbody.add_body(name=QUAD_BODY, pos=list(position), quat=_yaw_quat(yaw))
    body.add_freejoint(name=QUAD_JOINT)
    body.explicitinertial = True
    body.mass = params.mass
    body.inertia = list(params.inertia)
    body.ipos = [0.0, 0.0, 0.0]

    def geom(collides: bool = True, **kwargs: object) -> None:
        g = body.add_geom(group=QUAD_GEOM_GROUP, **kwargs)
        g.contype = _QUAD_CONTYPE if collides else 0
        g.conaffinity = _QUAD_CONAFFINITY if collides else 0

    dark = [0.15, 0.15, 0.17, 1.0]
    geom(name="quad_core", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.09, 0.06, 0.035], rgba=dark)
    spin_rgba = {Spin.CCW: [0.8, 0.25, 0.2, 0.6], Spin.CW: [0.2, 0.35, 0.8, 0.6]}
    for i, rotor in enumerate(rotors(params)):
        x, y, z = rotor.position
        geom(
            collides=False,
            name=f"arm_{i}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0.0, 0.0, z - 0.02, x, y, z - 0.02],
            size=[0.012, 0.0, 0.0],
            rgba=dark,
        )
        geom(
            name=f"prop_{i}",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            pos=[x, y, z],
            size=[params.rotor_radius, 0.004, 0.0],
            rgba=spin_rgba[rotor.spin],
        )
        body.add_site(name=rotor_site_name(i), pos=[x, y, z], size=[0.01, 0.0, 0.0])
        foot_radius = 0.012
        geom(
            name=f"leg_{i}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0.45 * x, 0.45 * y, -0.03, 0.6 * x, 0.6 * y, -params.leg_height + foot_radius],
            size=[foot_radius, 0.0, 0.0],
            rgba=dark,
        )
        actuator = spec.add_actuator(
            name=motor_name(i),
            trntype=mujoco.mjtTrn.mjTRN_SITE,
            target=rotor_site_name(i),
            gear=[0.0, 0.0, 1.0, 0.0, 0.0, -int(rotor.spin) * params.torque_ratio],
            ctrlrange=[0.0, params.max_motor_thrust],
        )
        actuator.ctrllimited = True
    body.add_site(name=IMU_SITE, pos=[0.0, 0.0, 0.0], size=[0.01, 0.0, 0.0])
    for name, kind in (
        (ACCEL_SENSOR, mujoco.mjtSensor.mjSENS_ACCELEROMETER),
        (GYRO_SENSOR, mujoco.mjtSensor.mjSENS_GYRO),
    ):
        spec.add_sensor(name=name, type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, objname=IMU_SITE)
    _add_camera(body, DOWN_CAMERA, params.down_camera, [0.0, -1.0, 0.0, 1.0, 0.0, 0.0])
    _add_camera(body, DEPTH_CAMERA, params.depth_camera, [0.0, -1.0, 0.0, 0.0, 0.0, 1.0])


def build_spec(
    arena: ArenaSpec,
    quad: QuadrotorParams | None = None,
    lighting: Lighting | None = None,
    *,
    timestep_us: int = DEFAULT_TIMESTEP_US,
    px_per_module: int = DEFAULT_PX_PER_MODULE,
) -> mujoco.MjSpec:
    """The uncompiled scene: arena plus quadrotor standing on the start pad, facing east."""
    if timestep_us <= 0:
        raise ValueError(f"timestep_us: {timestep_us} must be > 0")
    quad = QuadrotorParams() if quad is None else quad
    spec = mujoco.MjSpec()
    spec.modelname = f"quadmission_{arena.name}"
    spec.option.timestep = timestep_us * 1e-6
    spec.option.gravity = [0.0, 0.0, -GRAVITY]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    ContestArena(arena, lighting=lighting, px_per_module=px_per_module).build(spec)
    x, y, z = arena.takeoff_position
    add_quadrotor(spec, quad, (x, y, z + quad.leg_height))

    sx, sy, sz = arena.field.size
    extent = math.sqrt(sx * sx + sy * sy + sz * sz) / 2.0
    spec.stat.extent = extent
    spec.stat.center = [sx / 2.0, sy / 2.0, sz / 2.0]
    spec.visual.map.znear = ZNEAR / extent
    spec.visual.map.zfar = ZFAR / extent
    onboard = (quad.down_camera, quad.depth_camera)
    sizes = [top_view_size(arena), *((camera.width, camera.height) for camera in onboard)]
    spec.visual.global_.offwidth = max(w for w, _ in sizes)
    spec.visual.global_.offheight = max(h for _, h in sizes)
    return spec


def build_model(
    arena: ArenaSpec,
    quad: QuadrotorParams | None = None,
    lighting: Lighting | None = None,
    *,
    timestep_us: int = DEFAULT_TIMESTEP_US,
    px_per_module: int = DEFAULT_PX_PER_MODULE,
) -> mujoco.MjModel:
    """Compile the scene for ``arena`` with ``quad`` (defaults: :class:`QuadrotorParams`)."""
    spec = build_spec(arena, quad, lighting, timestep_us=timestep_us, px_per_module=px_per_module)
    return spec.compile()
