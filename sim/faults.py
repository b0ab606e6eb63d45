"""The faults that act in the simulator, on the FCU link and in the FCU (issue 22).

:func:`install_faults` adds them to a :class:`~sim.fcu.sitl.Sitl`, scheduled in simulated
time; nothing here touches the companion:

- ``vio_stop``: the simulated visual odometry (:class:`~sim.vision.VisionPose`) stops
  publishing for the fault's duration;
- ``link_lost``: the serial link (:class:`~sim.fcu.link.Link`) loses every message, both
  ways, for the duration;
- ``battery_low`` / ``battery_critical``: the pack (and with it PX4's estimate) sags to a
  charge below ``BAT_LOW_THR`` / ``BAT_CRIT_THR`` of the FCU's battery parameters;
- ``wind_gust``: a horizontal force on the quadrotor's body (:class:`Gusts`, the
  actuation's :class:`~sim.world.Wind`), exactly over ``[at_s, at_s + duration_s)``;
- ``vio_jump`` / ``vio_delay``: the visual odometry shifts by an offset for good, or is
  published later for the duration (:class:`~sim.vision.VisionPose`'s ``offset`` and
  ``extra_latency_s``);
- ``latency_spike`` / ``packet_burst``: every link message, both ways, is later, or lost
  with a probability, for the duration (:class:`~sim.fcu.link.Link`);
- ``clock_jump``: the companion's clock as the XRCE agent reads it to answer the FCU's
  time sync jumps (:class:`~sim.fcu.agent.FcuAgentNode`'s ``clock_offset_ns``): the
  FCU's offset estimate must follow, and the bridge's conversions with it;
- ``camera_dark`` / ``depth_dark``: the sensors node's image (point-cloud) publisher is
  wrapped (:class:`Blackout`): black images (empty clouds) for the duration, the
  sensors' code untouched;
- ``pad_occluded`` / ``robot_absent``: the pad's (robot's) marker geom loses its texture
  (a plain pad, a plain robot top): the marker is gone, the thing is still there;
- ``light_drop``: the lights go to the ``dark`` preset (:data:`~sim.mjcf.LIGHTING_PRESETS`);
- ``robot_across``: a ground robot leaves its route and drives straight across the
  vehicle's path (:func:`across_drive`, from the vehicle's true position and velocity at
  the fault's time), then stops (the robots' part, :class:`~sim.world.RobotMotion`).

The switches run in a world part (:class:`FaultSwitches`) at ``rate_hz``, before the
other parts of a tick: a fault starts at the first tick at or after its time (on time
when the time is a multiple of 10 ms, at 100 Hz). Kinds that act
elsewhere (the operator's) are left to the app. Same faults, same seed: same run.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

import interfaces
from runtime.clock import NS_PER_S
from sim.arena import ROBOT_SIZE, ArenaSpec, Lighting, StraightDrive, robot_pose
from sim.errors import SimError
from sim.fault_spec import Fault, FaultKind
from sim.fcu.agent import FcuAgentNode
from sim.fcu.battery import BatteryEstimatorParams
from sim.fcu.firmware import Firmware
from sim.fcu.link import Link
from sim.fcu.sitl import Sitl
from sim.mjcf import LIGHTING_PRESETS, pad_geom_name, robot_body_name
from sim.scene import quad_state
from sim.vision import VisionPose
from sim.world import FloatArray, RobotMotion, Scene, Wind

if TYPE_CHECKING:
    from sim.sensors import SimSensorsNode

__all__ = ["SIM_KINDS", "Blackout", "FaultInstallError", "FaultSwitches", "Gusts", "Switched",
           "across_drive", "install_faults", "sag_level"]

SIM_KINDS = frozenset({
    FaultKind.VIO_STOP, FaultKind.LINK_LOST, FaultKind.BATTERY_LOW,
    FaultKind.BATTERY_CRITICAL, FaultKind.WIND_GUST, FaultKind.VIO_JUMP, FaultKind.VIO_DELAY,
    FaultKind.LATENCY_SPIKE, FaultKind.PACKET_BURST, FaultKind.CLOCK_JUMP,
    FaultKind.CAMERA_DARK, FaultKind.DEPTH_DARK, FaultKind.PAD_OCCLUDED,
    FaultKind.LIGHT_DROP, FaultKind.ROBOT_ABSENT, FaultKind.ROBOT_ACROSS})
"""The kinds this module injects."""
CAMERA_KINDS = frozenset({FaultKind.CAMERA_DARK, FaultKind.DEPTH_DARK})
"""The kinds that need the sensors node."""
_WINDOWED = frozenset({FaultKind.VIO_STOP, FaultKind.LINK_LOST, FaultKind.VIO_DELAY,
                       FaultKind.LATENCY_SPIKE, FaultKind.PACKET_BURST, *CAMERA_KINDS})
PLAIN_PAD_RGBA = (0.55, 0.8, 0.95, 1.0)  # the pad's light blue, without its marker
PLAIN_ROBOT_RGBA = (0.3, 0.3, 0.3, 1.0)


class FaultInstallError(SimError, ValueError):
    """A fault that cannot act in this run; the message names the kind and why."""


def _ns(t_s: float) -> int:
    return round(t_s * NS_PER_S)


@dataclass
class Gusts:
    """The wind a run had before (``base``) plus each gust's force while it blows."""

    base: Wind
    gusts: Sequence[Fault]

    def __post_init__(self) -> None:
        self._windows = []
        for g in self.gusts:
            heading = math.radians(g.value("direction_deg"))
            force = g.value("force")
            vector = np.array([force * math.cos(heading), force * math.sin(heading), 0.0])
            self._windows.append((_ns(g.at_s), _ns(g.end_s), vector))

    def force(self, t_ns: int) -> FloatArray:
        out = self.base.force(t_ns)
        for start, end, vector in self._windows:
            if start <= t_ns < end:
                out = out + vector
        return out


def sag_level(kind: FaultKind, params: BatteryEstimatorParams) -> float:
    """The charge a battery fault leaves by default: half way into its warning band."""
    if kind is FaultKind.BATTERY_LOW:
        return (params.crit_thr + params.low_thr) / 2.0
    if kind is FaultKind.BATTERY_CRITICAL:
        return (params.emergen_thr + params.crit_thr) / 2.0
    raise ValueError(f"{kind.value} is not a battery fault")


HOVERING_M_S = 0.1  # m/s: slower than this, the vehicle's path is along its heading


def across_drive(fault: Fault, t_s: float, arena: ArenaSpec, vehicle_xy: tuple[float, float],
                 vehicle_velocity_xy: tuple[float, float],
                 heading: float) -> tuple[int, StraightDrive]:
    """``robot_across``'s drive: the crossing point is ``ahead`` m in front of the vehicle
    (along its horizontal velocity, or its ``heading`` [rad, from +x] when hovering), kept
    on the field; the robot (``robot``, or the one nearest that point) drives from where
    it is at ``t_s`` straight through it and ``beyond`` m further (less where the field
    ends), at ``speed``. The robot's index in ``arena.robots`` and its drive."""
    vx, vy = vehicle_velocity_xy
    speed = math.hypot(vx, vy)
    ux, uy = (vx / speed, vy / speed) if speed > HOVERING_M_S else (
        math.cos(heading), math.sin(heading))
    half = max(ROBOT_SIZE[0], ROBOT_SIZE[1]) / 2.0
    size_x, size_y = arena.field.size[0], arena.field.size[1]
    ahead = fault.value("ahead")
    cx = min(max(vehicle_xy[0] + ahead * ux, half), size_x - half)
    cy = min(max(vehicle_xy[1] + ahead * uy, half), size_y - half)
    starts = [robot_pose(r, t_s).xy for r in arena.robots]
    marker = fault.value("robot")
    if math.isnan(marker):
        index = min(range(len(starts)), key=lambda i: math.dist(starts[i], (cx, cy)))
    else:
        index = [r.marker_id for r in arena.robots].index(int(marker))
    (sx, sy) = starts[index]
    gap = math.dist((sx, sy), (cx, cy))
    dx, dy = ((cx - sx) / gap, (cy - sy) / gap) if gap > 1e-9 else (-uy, ux)
    # how far the field lets it go past the crossing point along (dx, dy)
    room = math.inf
    for d, c, hi in ((dx, cx, size_x - half), (dy, cy, size_y - half)):
        if d > 1e-12:
            room = min(room, (hi - c) / d)
        elif d < -1e-12:
            room = min(room, (half - c) / d)
    further = min(fault.value("beyond"), max(room, 0.0))
    end = (cx + dx * further, cy + dy * further)
    return index, StraightDrive(t_s, (sx, sy), end, fault.value("speed"))


@dataclass(frozen=True)
class Switched:
    """A fault switched on (``on=True``) or off at ``t_s`` of simulated time."""

    t_s: float
    fault: Fault
    on: bool


def _black_image(msg: Any) -> Any:
    return interfaces.new("sensor_msgs/msg/Image", header=msg.header, height=msg.height,
                          width=msg.width, encoding=msg.encoding, step=msg.step,
                          data=np.zeros_like(msg.data))


def _empty_cloud(msg: Any) -> Any:
    return interfaces.new("sensor_msgs/msg/PointCloud2", header=msg.header, height=1,
                          width=0, fields=msg.fields, is_bigendian=msg.is_bigendian,
                          point_step=msg.point_step, row_step=0,
                          data=np.zeros(0, dtype=np.uint8), is_dense=True)


class Blackout:
    """Stands in for a sensor's publisher: passes every message through, blanked (black
    image, empty cloud) while ``dark``; anything else is the publisher's."""

    def __init__(self, publisher: Any, blank: Callable[[Any], Any]) -> None:
        self.publisher = publisher
        self.blank = blank
        self.dark = False

    def publish(self, msg: Any) -> None:
        self.publisher.publish(self.blank(msg) if self.dark else msg)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.publisher, name)


def _plain(scene: Scene, geom: str, rgba: tuple[float, ...]) -> None:
    """Take the texture (the marker) off ``geom``: a plain colour instead."""
    gid = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_GEOM, geom)
    if gid < 0:
        raise FaultInstallError(f"no geom {geom!r} in the arena")
    scene.model.geom_matid[gid] = -1
    scene.model.geom_rgba[gid] = rgba


def _lights_to(scene: Scene, lighting: Lighting) -> None:
    preset = LIGHTING_PRESETS[lighting]
    vis = scene.model.vis.headlight
    vis.ambient[:] = preset.headlight_ambient
    vis.diffuse[:] = preset.headlight_diffuse
    lid = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_LIGHT, "overhead")
    if lid >= 0:
        scene.model.light_diffuse[lid] = preset.overhead_diffuse


@dataclass
class FaultSwitches:
    """The world part that switches the faults on and off at their times."""

    faults: Sequence[Fault]
    vision: VisionPose
    link: Link
    firmware: Firmware
    agent: FcuAgentNode | None = None
    image: Blackout | None = None
    cloud: Blackout | None = None
    robots: RobotMotion | None = None
    rate_hz: float = 100.0
    name: str = "faults"
    switched: list[Switched] = field(default_factory=list)
    """What was switched when (ground truth for the report)."""

    def __post_init__(self) -> None:
        events = []
        for f in self.faults:
            if f.kind in SIM_KINDS and f.kind is not FaultKind.WIND_GUST:
                events.append((_ns(f.at_s), True, f))
                if math.isfinite(f.end_s) and f.kind in _WINDOWED:
                    events.append((_ns(f.end_s), False, f))
        # in time order; at the same time an end before a start (windows are half-open)
        self._pending = sorted(events, key=lambda e: (e[0], e[1]))
        self._active: list[Fault] = []  # the windowed faults on now (they may overlap)

    def update(self, t_ns: int, scene: Scene) -> None:
        while self._pending and self._pending[0][0] <= t_ns:
            _, on, fault = self._pending.pop(0)
            if fault.kind in _WINDOWED:
                if on:
                    self._active.append(fault)
                else:
                    self._active.remove(fault)
                self._windows()
            else:
                self._step(fault, scene, t_ns)
            self.switched.append(Switched(t_ns / NS_PER_S, fault, on))

    def _windows(self) -> None:
        """What the windowed faults on now add up to (an end restores what no other
        fault still holds)."""
        kinds = [f.kind for f in self._active]
        self.vision.tracking = FaultKind.VIO_STOP not in kinds
        self.link.down = FaultKind.LINK_LOST in kinds
        self.vision.extra_latency_s = sum(f.value("delay_ms") for f in self._active
                                          if f.kind is FaultKind.VIO_DELAY) / 1e3
        self.link.extra_latency_us = sum(f.value("latency_ms") for f in self._active
                                         if f.kind is FaultKind.LATENCY_SPIKE) * 1e3
        self.link.extra_loss_probability = max(
            (f.value("loss") for f in self._active if f.kind is FaultKind.PACKET_BURST),
            default=0.0)
        if self.image is not None:
            self.image.dark = FaultKind.CAMERA_DARK in kinds
        if self.cloud is not None:
            self.cloud.dark = FaultKind.DEPTH_DARK in kinds

    def _step(self, fault: Fault, scene: Scene, t_ns: int) -> None:
        kind = fault.kind
        if kind is FaultKind.ROBOT_ACROSS:
            assert self.robots is not None
            truth = quad_state(scene.data, scene.index)
            w, x, y, z = truth.quaternion.tolist()
            heading = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
            p, v = truth.position.tolist(), truth.velocity.tolist()
            index, drive = across_drive(fault, t_ns / NS_PER_S, scene.arena, (p[0], p[1]),
                                        (v[0], v[1]), heading)
            self.robots.drives[index] = drive
        elif kind is FaultKind.VIO_JUMP:
            o = self.vision.offset
            self.vision.offset = (o[0] + fault.value("x"), o[1] + fault.value("y"),
                                  o[2] + fault.value("z"))
        elif kind is FaultKind.CLOCK_JUMP:
            assert self.agent is not None
            self.agent.clock_offset_ns += round(fault.value("offset_ms") * 1e6)
        elif kind is FaultKind.PAD_OCCLUDED:
            _plain(scene, pad_geom_name(int(fault.value("pad"))), PLAIN_PAD_RGBA)
        elif kind is FaultKind.ROBOT_ABSENT:
            _plain(scene, f"{robot_body_name(int(fault.value('robot')))}_marker",
                   PLAIN_ROBOT_RGBA)
        elif kind is FaultKind.LIGHT_DROP:
            _lights_to(scene, Lighting.DARK)
        else:  # a battery sag
            fw = self.firmware
            params = fw.battery_estimator.params
            level = fault.value("remaining")
            if math.isnan(level):
                level = sag_level(fault.kind, params)
            fw.battery_model.sag_to(level)
            fw.battery_estimator.sag_to(level)


def install_faults(sitl: Sitl, faults: Sequence[Fault],
                   sensors: SimSensorsNode | None = None) -> FaultSwitches | None:
    """Schedule the simulator's faults of ``faults`` in ``sitl``: the switches as an
    extra part, the gusts in the actuation's wind, the cameras' blackouts around
    ``sensors``' publishers. None (and ``sitl`` untouched) when none of them acts in the
    simulator, so a run without faults is the run it was. A fault that cannot act in
    this run (a camera without ``sensors``, a marker the arena lacks, a robot not named)
    raises :class:`FaultInstallError` naming it."""
    ours = [f for f in faults if f.kind in SIM_KINDS]
    if not ours:
        return None
    kinds = {f.kind for f in ours}
    if kinds & CAMERA_KINDS and sensors is None:
        names = ", ".join(sorted(k.value for k in kinds & CAMERA_KINDS))
        raise FaultInstallError(f"{names}: this run has no cameras to darken")
    arena = sitl.scene.arena
    for f in ours:
        if f.kind is FaultKind.PAD_OCCLUDED and int(f.value("pad")) not in arena.pad_ids:
            raise FaultInstallError(f"{f.spec()}: arena {arena.name!r} has pads "
                                    f"{list(arena.pad_ids)}")
        robots = [r.marker_id for r in arena.robots]
        if f.kind is FaultKind.ROBOT_ABSENT and (
                math.isnan(f.value("robot")) or int(f.value("robot")) not in robots):
            raise FaultInstallError(f"{f.spec()}: name the robot's marker, one of "
                                    f"{robots} (robot=ID)")
        if f.kind is FaultKind.ROBOT_ACROSS and (not robots or (
                not math.isnan(f.value("robot")) and int(f.value("robot")) not in robots)):
            raise FaultInstallError(f"{f.spec()}: arena {arena.name!r} has robots {robots}")
    gusts = [f for f in ours if f.kind is FaultKind.WIND_GUST]
    if gusts:
        sitl.actuation.wind = Gusts(sitl.actuation.wind, gusts)
    image = cloud = None
    if sensors is not None and kinds & CAMERA_KINDS:
        image = Blackout(sensors.down_image, _black_image)
        cloud = Blackout(sensors.depth_points, _empty_cloud)
        sensors.down_image, sensors.depth_points = image, cloud  # type: ignore[assignment]
    switches = FaultSwitches(ours, sitl.vision, sitl.link, sitl.firmware, sitl.agent,
                             image, cloud, sitl.robots)
    sitl.first_parts.append(switches)
    return switches
