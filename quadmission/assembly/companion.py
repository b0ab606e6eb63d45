"""The companion computer's flight stack on top of a software-in-the-loop FCU.

:func:`start_companion` adds the FCU bridge, the visual-odometry forwarder and (unless
asked not to) the flight-control node to a :class:`~sim.fcu.sitl.Sitl`'s executor. Facts
the companion cannot know by itself come from the app, here: the flyable volume is the
arena's field, passed to the flight-control node as its ``field_min``/``field_max``.
Tests and scenarios use it; under ``--transport ros2`` the same nodes run as processes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from flight_control.bridge_node import FcuBridgeNode
from flight_control.flight_control_node import FlightControlNode
from flight_control.params import FlightControlParams
from flight_control.vio_node import VioNode
from fsm.params import MissionParams
from navigation.params import NavigatorParams, PathFinderParams
from navigation.voxel_graph import top_cube_centre
from runtime.errors import ParameterError
from runtime.parameters import load_parameters

if TYPE_CHECKING:
    from sim.arena import ArenaSpec
    from sim.fcu.sitl import Sitl
    from sim.quadrotor import CameraParams


@dataclass
class Companion:
    bridge: FcuBridgeNode
    vio: VioNode
    flight_control: FlightControlNode | None


def field_bounds(arena: ArenaSpec) -> dict[str, list[float]]:
    """The flight-control node's ``field_min``/``field_max`` [m, map frame] for ``arena``:
    the floor rectangle up to the ceiling."""
    x, y, z = arena.field.size
    return {"field_min": [0.0, 0.0, 0.0], "field_max": [float(x), float(y), float(z)]}


def planning_bounds(arena: ArenaSpec) -> dict[str, Any]:
    """The path finder's field bounds and altitude band: it plans only where the
    flight-control node flies (below the ceiling by its ``wall_clearance``, at or above its
    floor ``min_altitude``)."""
    fc = load_parameters(FlightControlParams, "flight_control")
    return field_bounds(arena) | {"ceiling_clearance": fc.wall_clearance,
                                  "min_altitude": fc.min_altitude}


def navigator_overrides(arena: ArenaSpec) -> dict[str, Any]:
    """The navigator's facts from the app: the arena's field, name and start pad."""
    return field_bounds(arena) | {"arena": arena.name, "start_pad": arena.start_pad}


def check_mission_altitudes(arena: ArenaSpec, mission: MissionParams | None = None) -> None:
    """ParameterError unless the mission's cruise and explore altitudes are heights the
    path finder plans at: a goal above its top cube would be flown at that cube's height
    (and spaced for the one asked), one above the cube's reach not flown at all."""
    mission = mission or load_parameters(MissionParams, "mission")
    finder = load_parameters(PathFinderParams, "path_finder")
    bounds = planning_bounds(arena)
    ceiling = min(finder.max_altitude, arena.field.size[2] - bounds["ceiling_clearance"])
    top = round(top_cube_centre(finder.resolution, ceiling), 6)
    floor = bounds["min_altitude"]
    for name in ("cruise_altitude", "explore_altitude"):
        value = getattr(mission, name)
        if not floor <= value <= top + 1e-9:
            raise ParameterError(
                f"mission.{name}: {value} m is outside the heights the path finder plans at, "
                f"{floor}-{top} m (its {finder.resolution} m cubes up to max_altitude "
                f"{finder.max_altitude} m, under the {arena.field.size[2]} m ceiling less "
                f"{bounds['ceiling_clearance']} m)")


def horizontal_half_fov(camera: CameraParams) -> float:
    """Half the camera's horizontal field of view [rad] (a pinhole: square pixels)."""
    return math.atan(math.tan(math.radians(camera.fovy_deg) / 2.0) * camera.width / camera.height)


def check_turn_first_angle(navigator: NavigatorParams | None = None,
                           depth_camera: CameraParams | None = None) -> None:
    """ParameterError unless a leg the navigator flies without turning to face it first
    lies inside the depth camera's horizontal field of view: the map ahead of a leg is
    what that camera saw, and the vehicle yaws onto a leg slowly while it flies it. At
    45 deg against a 36.5 deg half field of view, random arena 208 flew a leg past a box
    face the camera had never looked at, and hit it."""
    from sim.quadrotor import onboard_cameras

    navigator = navigator or load_parameters(NavigatorParams, "navigator")
    camera = depth_camera or onboard_cameras().depth_camera
    half = horizontal_half_fov(camera)
    if navigator.turn_first_angle >= half:
        raise ParameterError(
            f"navigator.turn_first_angle: {navigator.turn_first_angle} rad "
            f"({math.degrees(navigator.turn_first_angle):.1f} deg) is not inside the depth "
            f"camera's horizontal half field of view, {half:.3f} rad "
            f"({math.degrees(half):.1f} deg: {camera.fovy_deg} deg vertical, "
            f"{camera.width}x{camera.height} px): a leg flown without turning first would "
            "leave the camera's view")


def start_companion(sitl: Sitl, *, flight_control: bool = True,
                    flight_control_overrides: dict[str, Any] | None = None,
                    **bridge_overrides: Any) -> Companion:
    """Bridge, VIO forwarder and flight-control node in ``sitl``'s executor, with config/
    parameters, the arena's field bounds and the overrides given."""
    context = sitl.executor.context
    bridge = FcuBridgeNode(context=context, parameter_overrides=bridge_overrides)
    vio = VioNode(context=context)
    fc = None
    if flight_control:
        overrides = field_bounds(sitl.scene.arena) | (flight_control_overrides or {})
        fc = FlightControlNode(context=context, parameter_overrides=overrides)
    for node in (bridge, vio, fc):
        if node is not None:
            sitl.executor.add_node(node)
    return Companion(bridge, vio, fc)
