"""The navigation nodes' parameters: types, units and ranges here, values in
``config/mapping.yaml``, ``config/path_finder.yaml``, ``config/navigator.yaml`` and
``config/precision_land.yaml``. The field bounds (``field_min``/``field_max``) come from
the app, as for flight_control."""

from __future__ import annotations

from dataclasses import dataclass, fields

from navigation.precision_landing import LandingParams, LandingStrategy
from navigation.voxel_graph import GraphParams
from runtime import param
from runtime.parameters import validate_parameters


@dataclass(frozen=True)
class MappingParams:
    """Parameters of ``mapping``."""

    voxel_size: float = param(unit="m", range=(0.01, 1.0), lo_open=False,
                              description="map voxel side (one point per voxel)")
    process_rate_hz: float = param(unit="Hz", range=(0.1, 100.0),
                                   description="depth clouds fused per second at most")
    publish_rate_hz: float = param(unit="Hz", range=(0.05, 50.0),
                                   description="/map/points publish rate")
    min_range: float = param(unit="m", range=(0.0, 100.0),
                             description="depth points nearer than this are dropped")
    max_range: float = param(unit="m", range=(0.1, 100.0),
                             description="depth points farther than this are dropped")
    settle_s: float = param(unit="s", range=(0.0, 60.0),
                            description="fuse only once the FCU's position has been valid "
                                        "this long")
    min_z: float = param(unit="m", range=(-100.0, 100.0),
                         description="map points below this height (the floor) are dropped")
    depth_camera_position: tuple[float, ...] = param(
        unit="m", range=(-2.0, 2.0),
        description="depth camera optical centre in the body frame (FLU); axes = body axes")
    map_file: str = param("", description="PCD/PLY map loaded at start; empty = none")
    health_rate_hz: float = param(1.0, unit="Hz", range=(0.1, 10.0),
                                  description="~/health publish rate")


@dataclass(frozen=True)
class PathFinderParams:
    """Parameters of ``path_finder``."""

    resolution: float = param(unit="m", range=(0.02, 2.0), description="cube side")
    occupied_threshold: int = param(range=(0, 100000),
                                    description="a cube with more points is non-viable")
    corridor_threshold: int = param(range=(1, 100000),
                                    description="an edge needs fewer points in its corridor")
    footprint_radius: float = param(unit="m", range=(0.0, 5.0),
                                    description="drone horizontal half-width")
    safety_margin: float = param(unit="m", range=(0.0, 5.0),
                                 description="added to the footprint")
    vertical_clearance: float = param(unit="m", range=(0.0, 5.0),
                                      description="corridor half-height")
    unknown_is_occupied: bool = param(description="unobserved cubes are non-viable")
    ceiling_clearance: float = param(unit="m", range=(0.0, 5.0),
                                     description="waypoints stay this far below the ceiling "
                                     "(the app sets flight control's wall_clearance)")
    max_altitude: float = param(unit="m", range=(0.5, 100.0),
                                description="waypoints stay at or below this height above "
                                "the floor: above, the depth camera has not seen the space")
    min_altitude: float = param(unit="m", range=(0.0, 100.0),
                                description="waypoints stay at or above this height "
                                "(the app sets flight control's min_altitude)")
    heuristic: str = param(choices=("euclidean", "octile"),
                           description="A* heuristic: the seed's Euclidean, or octile")
    snap_radius: float = param(unit="m", range=(0.0, 5.0),
                               description="start/goal snap to a free cube within this")
    max_expansions: int = param(range=(1000, 100_000_000),
                                description="search limit in cubes expanded (a count, not host "
                                            "time, so the same map gives the same plan)")
    use_live_map: bool = param(description="plan on /map/points (else only map_file)")
    map_file: str = param("", description="PCD/PLY map loaded at start; empty = none")
    cache_dir: str = param("", description="graph cache folder; empty = no disk cache")
    health_rate_hz: float = param(1.0, unit="Hz", range=(0.1, 10.0),
                                  description="~/health publish rate")

    def graph(self, clearance: float = 0.0) -> GraphParams:
        """The graph parameters; a request's ``clearance`` > 0 replaces footprint + margin."""
        radius, margin = ((clearance, 0.0) if clearance > 0.0
                          else (self.footprint_radius, self.safety_margin))
        return GraphParams(resolution=self.resolution,
                           occupied_threshold=self.occupied_threshold,
                           corridor_threshold=self.corridor_threshold,
                           footprint_radius=radius, safety_margin=margin,
                           vertical_clearance=self.vertical_clearance,
                           unknown_is_occupied=self.unknown_is_occupied,
                           ceiling_clearance=self.ceiling_clearance,
                           max_altitude=self.max_altitude,
                           min_altitude=self.min_altitude)


@dataclass(frozen=True)
class NavigatorParams:
    """Parameters of ``navigator``."""

    cruise_altitude: float = param(unit="m", range=(0.3, 10.0),
                                   description="flight height (map z) of takeoff and explore")
    cruise_speed: float = param(unit="m/s", range=(0.1, 5.0), description="reach speed")
    pass_stop_s: float = param(unit="s", range=(0.0, 5.0),
                               description="a point passed at speed v is stopped within "
                                           "v times this past it: it is passed only when "
                                           "the way on is clear that far")
    waypoint_radius: float = param(unit="m", range=(0.02, 2.0),
                                   description="an intermediate waypoint is reached inside it")
    goal_radius: float = param(unit="m", range=(0.02, 2.0),
                               description="the goal is reached inside it (goal's 0)")
    replan_period_s: float = param(unit="s", range=(0.1, 60.0),
                                   description="re-plan from here this often while flying")
    replan_tolerance: float = param(unit="m", range=(0.0, 100.0),
                                    description="switch path when its length differs more")
    corner_cut: float = param(unit="m", range=(0.02, 2.0),
                              description="the flown chord cuts a corner by at most this")
    map_wait_s: float = param(unit="s", range=(0.0, 60.0),
                              description="after a turn, wait this long at most for a map "
                                          "holding a depth cloud captured after it")
    plan_attempts: int = param(range=(1, 100), description="plans tried before giving up")
    max_reach_failures: int = param(range=(0, 100),
                                    description="failed reaches (each re-planned) tolerated")
    turn_first_angle: float = param(unit="rad", range=(0.0, 3.15),
                                    description="turn to face a leg first beyond this angle "
                                                "(3.15: never)")
    survey_turns: int = param(range=(0, 8), description="quarter turns after takeoff, to "
                                                         "map around with the depth camera")
    explore_paths_file: str = param(description="YAML of explore paths per arena and pad")
    replace_blocked_lane_ends: bool = param(
        description="an explore waypoint with no path is replaced by the nearest point "
                    "toward its lane's other end reached along the lane (else skipped)")
    explore_sweeps: int = param(range=(1, 20),
                                description="sweeps of the area while no stop marker is "
                                            "seen: the explore path, then lanes along and "
                                            "across in turn")
    lane_point_spacing: float = param(
        unit="m", range=(0.5, 100.0),
        description="a coverage lane is flown through points on it at most this far apart, "
                    "so a detour round an obstacle comes back to the lane")
    lane_overlap: float = param(unit="1", range=(0.0, 0.9),
                                description="coverage lanes overlap of the camera footprint")
    down_camera_fovy_deg: float = param(unit="deg", range=(1.0, 179.0),
                                        description="down camera vertical field of view")
    down_camera_aspect: float = param(unit="1", range=(0.1, 10.0),
                                      description="down camera width / height")
    wall_margin: float = param(unit="m", range=(0.0, 5.0),
                               description="coverage lanes stay this far from the walls")
    coverage_cell: float = param(unit="m", range=(0.05, 5.0),
                                 description="cell of the coverage estimate")
    feedback_rate_hz: float = param(unit="Hz", range=(0.1, 50.0),
                                    description="action feedback rate")
    arena: str = param("", description="arena name (explore paths key); from the app")
    start_pad: int = param(0, range=(0, 1000), description="start pad id; from the app")
    health_rate_hz: float = param(1.0, unit="Hz", range=(0.1, 10.0),
                                  description="~/health publish rate")


@dataclass(frozen=True)
class PrecisionLandParams:
    """Parameters of ``precision_land``; values live in ``config/precision_land.yaml``.
    The algorithm's are :class:`LandingParams` field for field."""

    strategy: LandingStrategy  # seed (latest pose) or capture (ours)
    max_tilt: float = param(unit="rad", range=(0.001, 1.0))
    filter_gain: float = param(range=(0.0, 1.0), lo_open=True)
    resolution: float = param(unit="m", range=(0.0, 0.1))
    align_radius: float = param(unit="m", range=(0.001, 1.0))
    max_align_speed: float = param(unit="m/s", range=(0.001, 2.0))
    descent_step: float = param(unit="m", range=(0.01, 2.0))
    min_altitude: float = param(unit="m", range=(0.1, 5.0))
    search_altitude: float = param(unit="m", range=(0.1, 10.0))
    search_spacing: float = param(unit="m", range=(0.05, 5.0))
    search_rings: int = param(range=(0, 10))
    search_detour: float = param(unit="m", range=(0.0, 20.0),
                                 description="a search point reached only by a way round "
                                             "longer than the straight line by more is skipped")
    search_timeout_s: float = param(unit="s", range=(0.1, 600.0))
    lost_timeout_s: float = param(unit="s", range=(0.1, 60.0))
    retries: int = param(range=(0, 10))
    timeout_s: float = param(unit="s", range=(1.0, 3600.0))
    outlier_distance: float = param(unit="m", range=(0.01, 5.0))
    height_tolerance: float = param(unit="m", range=(0.01, 5.0))
    max_rejections: int = param(range=(1, 100))
    min_fresh_frames: int = param(range=(1, 100))
    pad_filter_gain: float = param(range=(0.0, 1.0), lo_open=True)
    land_radius: float = param(unit="m", range=(0.001, 1.0))
    reach_speed: float = param(unit="m/s", range=(0.05, 2.0))
    reach_radius: float = param(unit="m", range=(0.02, 1.0))
    land_speed: float = param(unit="m/s", range=(0.05, 2.0))
    disarm: bool = param(description="disarm once landed")
    max_pad_distance: float = param(unit="m", range=(0.0, 100.0),
                                    description="goals farther than this are rejected")
    health_rate_hz: float = param(unit="Hz", range=(0.1, 10.0))
    poll_s: float = param(unit="s", range=(0.001, 1.0),
                          description="how often the goal looks at new frames")

    def __post_init__(self) -> None:
        validate_parameters(self)
        self.landing()  # cross-field checks

    def landing(self) -> LandingParams:
        names = {f.name for f in fields(LandingParams)}
        return LandingParams(**{n: getattr(self, n) for n in names})


__all__ = ["MappingParams", "NavigatorParams", "PathFinderParams", "PrecisionLandParams"]
