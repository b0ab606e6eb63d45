"""The ``navigate`` scenario: from the start pad to every other pad, each leg planned.

The companion stack (bridge, VIO, flight control) plus the navigation nodes (mapping from
the forward depth camera, the path finder on the live map, the navigator) fly over the
SITL. :class:`NavigatePilot`, a mission script, arms, asks ``/navigation/takeoff`` (climb
to the cruise altitude, then a full survey turn so the depth camera maps around), then one
``/navigation/navigate`` per pad, in an order drawn from the seed, to the hover point
above it. The planner never sees the arena: it plans on what the depth camera mapped
(unknown space free; the navigator re-plans as the map grows), around tall obstacles and
over the low ones. Ground truth is read only here, to judge the flight:

``report.json``: ``legs`` [{from, to, planned_length_m, flown_length_m, min_clearance_m,
reached}], ``crashed``, ``rmse_m`` {x, y, z} (setpoint vs flown), ``sim_time_s``;
``path.png``: the voxel map at the cruise altitude (non-viable cubes grey, as in seed
Figure 5) with the planned and flown paths. ``--scenario map-arena`` flies the same way
and saves the map (``map.pcd``) for an offline graph, as the seed built it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

import interfaces
from interfaces import graph
from navigation.errors import NavigationError
from navigation.mapping_node import MappingNode
from navigation.navigator_messages import NAVIGATE, TAKEOFF
from navigation.navigator_node import NavigatorNode
from navigation.path_finder_node import PLAN_PATH, PathFinderNode, path_points
from quadmission.assembly.companion import navigator_overrides, planning_bounds, start_companion
from quadmission.assembly.faults import check_faults, judge_flight
from quadmission.evaluation.faults import FcuFailsafes
from quadmission.evaluation.tracking import SetpointRecorder, rounded, tracking
from quadmission.reports.report import write_report
from quadmission.scenarios.pilot import Pilot
from sim.arena import ArenaSpec
from sim.faults import install_faults
from sim.fcu.sitl import build_sitl
from sim.render import SceneRenderer
from sim.sensors import SimSensorsNode, sensor_parts
from sim.world import StopWhen, Trajectory

if TYPE_CHECKING:
    from quadmission.scenarios.options import ScenarioOptions

LAND = graph.LAND.interface()
ARM_ATTEMPTS = 3
READY_TIMEOUT_S = 20.0  # s for flight control to report ready
CRUISE_ALTITUDE = 1.5  # m: the navigator's cruise altitude (config/navigator.yaml)
FLIGHT_LIMIT_S = 900.0  # s of simulated time before the run is declared stuck
PATH_IMAGE = "path.png"
MAP_FILE = "map.pcd"


@dataclass
class Leg:
    start_pad: int
    pad: int
    goal: tuple[float, float, float]
    planned: np.ndarray | None = None
    plan_message: str = ""
    started_s: float = math.nan
    ended_s: float = math.nan
    reached: bool = False
    message: str = ""


@dataclass
class _Script:
    legs: list[Leg]
    phase: str = "wait_ready"
    done: bool = False
    failure: str = ""
    takeoff_s: float = math.nan
    events: list[str] = field(default_factory=list)


class NavigatePilot(Pilot):
    """Arm, take off through the navigator, navigate to each leg's goal in turn, land."""

    def __init__(self, legs: list[Leg], *, land: bool = True, **kwargs: Any) -> None:
        super().__init__("navigate_pilot", (graph.PLAN_PATH, graph.NAVIGATION_TAKEOFF,
                                            graph.NAVIGATE, graph.LAND), **kwargs)
        self.script = _Script(legs)
        self.land_at_end = land
        self.planner = self.clients[graph.PLAN_PATH.name]
        self.position = np.zeros(3)
        odometry = graph.FCU_ODOMETRY
        self.create_subscription(odometry.type, odometry.name, self._on_odom,
                                 odometry.subscriber_qos)
        self.create_task(self._mission())

    def _on_odom(self, msg: Any) -> None:
        p = msg.pose.pose.position
        self.position = np.array([p.x, p.y, p.z])

    def _fail(self, why: str) -> None:
        self.script.failure = why
        self.script.phase = "failed"
        self.script.done = True

    async def _mission(self) -> None:
        s = self.script
        if not await self.wait_ready(READY_TIMEOUT_S):
            self._fail("flight control not ready")
            return
        s.phase = "arm"
        if await self.arm_vehicle(ARM_ATTEMPTS) is not None:
            self._fail("arm refused")
            return
        s.phase = "takeoff"
        reply = await self.goal(graph.NAVIGATION_TAKEOFF, interfaces.new(TAKEOFF.Goal))
        if not reply.success:
            self._fail(f"takeoff: {reply.message}")
            return
        s.takeoff_s = self.now().nanoseconds / 1e9
        for k, leg in enumerate(s.legs):
            s.phase = f"leg {k + 1}/{len(s.legs)} to pad {leg.pad}"
            goal = interfaces.new("geometry_msgs/msg/Point", x=leg.goal[0], y=leg.goal[1],
                                  z=leg.goal[2])
            here = interfaces.point(*self.position)
            plan = await self.planner.call_async(
                interfaces.new(PLAN_PATH.Request, start=here, goal=goal))
            leg.planned = path_points(plan.path) if plan.success else None
            leg.plan_message = str(plan.message)
            leg.started_s = self.now().nanoseconds / 1e9
            reply = await self.goal(graph.NAVIGATE, interfaces.new(NAVIGATE.Goal, goal=goal,
                                                                   yaw=math.nan))
            leg.ended_s = self.now().nanoseconds / 1e9
            leg.reached, leg.message = reply.success, reply.message
            s.events.append(f"pad {leg.pad}: "
                            f"{'reached' if reply.success else 'FAILED ' + reply.message}")
        if self.land_at_end:
            s.phase = "land"
            await self.goal(graph.LAND, interfaces.new(LAND.Goal, disarm=True))
        s.phase = "done"
        s.done = True


@dataclass
class _Progress:
    pilot: NavigatePilot
    say: Any
    name: str = "progress"
    rate_hz: float = 10.0
    _last: str = ""

    def update(self, t_ns: int, scene: Any) -> None:
        if self.pilot.script.phase != self._last:
            self._last = self.pilot.script.phase
            self.say(f"  t={t_ns / 1e9:6.1f} s  {self._last}")


def leg_order(arena: ArenaSpec, seed: int) -> list[int]:
    """The other pads in an order drawn from the seed."""
    others = [p.id for p in arena.pads if p.id != arena.start_pad]
    rng = np.random.default_rng(seed)
    return [others[i] for i in rng.permutation(len(others))]


def _box_distance(points: np.ndarray, arena: ArenaSpec) -> np.ndarray:
    """Distance [m] from each point to the nearest obstacle box (ground truth)."""
    best = np.full(len(points), np.inf)
    for o in arena.obstacles:
        cx, cy = o.center
        sx, sy, h = o.size
        lo = np.array([cx - sx / 2, cy - sy / 2, 0.0])
        hi = np.array([cx + sx / 2, cy + sy / 2, h])
        d = np.linalg.norm(np.maximum(np.maximum(lo - points, points - hi), 0.0), axis=1)
        best = np.minimum(best, d)
    return best


def _window(truth: Trajectory, t0: float, t1: float) -> np.ndarray:
    keep = (truth.t >= t0) & (truth.t <= t1)
    return truth.position[keep]


def fly_legs(options: ScenarioOptions, arena: ArenaSpec, *, scenario: str,
             save_map_to: str | None = None, limit_s: float = FLIGHT_LIMIT_S,
             pads: list[int] | None = None) -> dict[str, Any]:
    """Fly from the start pad to every other pad (seeded order; or to ``pads`` in that
    order); write report.json and path.png into ``options.out``; return the report."""
    check_faults(scenario, options.faults)
    sitl = build_sitl(arena, seed=options.seed)
    start_companion(sitl)
    context = sitl.executor.context
    mapping = MappingNode(context=context)
    finder = PathFinderNode(context=context, parameter_overrides=planning_bounds(arena))
    navigator = NavigatorNode(context=context, parameter_overrides=navigator_overrides(arena))
    start = arena.pad(arena.start_pad).center
    legs: list[Leg] = []
    prev = arena.start_pad
    for pad_id in leg_order(arena, options.seed) if pads is None else pads:
        x, y = arena.pad(pad_id).center
        legs.append(Leg(prev, pad_id, (float(x), float(y), CRUISE_ALTITUDE)))
        prev = pad_id
    pilot = NavigatePilot(legs, context=context)
    recorder = SetpointRecorder(context=context)
    sensors = SimSensorsNode(context=context)
    for node in (mapping, finder, navigator, pilot, recorder, sensors):
        sitl.executor.add_node(node)
    options.progress(f"  {len(legs)} legs from pad {arena.start_pad} at {start}: "
                     f"{[leg.pad for leg in legs]}")
    with SceneRenderer(sitl.scene.model) as renderer:
        # the depth camera renders only as often as the mapping node fuses clouds
        sitl.extra_parts.extend(sensor_parts(sensors, renderer, sitl.scene, seed=options.seed,
                                             depth_hz=mapping.params.process_rate_hz))
        sitl.extra_parts.append(_Progress(pilot, options.progress))
        failsafes = FcuFailsafes(sitl.firmware)
        if options.faults:  # a run without faults keeps the parts it had
            install_faults(sitl, options.faults, sensors=sensors)
            sitl.extra_parts.append(failsafes)
        result = sitl.run(limit_s, stop=StopWhen(lambda: pilot.script.done))
    truth, crash = result.trajectory, result.crash
    options.progress(f"  map: {len(mapping.map)} voxels from {mapping.clouds_fused} clouds "
                     f"({mapping.clouds_dropped} without a pose)")
    if save_map_to is not None:
        mapping.save(options.out / save_map_to)

    leg_reports = []
    for leg in legs:
        flown = _window(truth, leg.started_s, leg.ended_s) if math.isfinite(leg.ended_s) \
            else np.zeros((0, 3))
        flown_len = float(np.linalg.norm(np.diff(flown, axis=0), axis=1).sum()) \
            if len(flown) > 1 else None
        clearance = float(_box_distance(flown, arena).min()) if len(flown) else None
        planned_len = None if leg.planned is None else float(
            np.linalg.norm(np.diff(leg.planned, axis=0), axis=1).sum())
        leg_reports.append({"from": leg.start_pad, "to": leg.pad,
                            "planned_length_m": rounded(planned_len, 3),
                            "flown_length_m": rounded(flown_len, 3),
                            "min_clearance_m": rounded(clearance, 3),
                            "reached": leg.reached, "message": leg.message})
    end_s = crash.t_s if crash is not None else result.sim_time_s
    window = (pilot.script.takeoff_s if math.isfinite(pilot.script.takeoff_s) else end_s,
              max((leg.ended_s for leg in legs if math.isfinite(leg.ended_s)), default=end_s))
    stamps, setpoints = recorder.samples()
    track = tracking(stamps, setpoints, truth, window)
    rmse = {k: rounded(v) for k, v in track.rmse().items() if k in "xyz"}
    reached = sum(1 for leg in legs if leg.reached)
    ok = crash is None and reached == len(legs)
    if crash is not None:
        verdict = f"CRASH: {crash.reason} at {crash.t_s:.1f} s ({reached}/{len(legs)} pads)"
    elif ok:
        verdict = f"reached {reached}/{len(legs)} pads"
    else:
        why = pilot.script.failure or ("not finished" if not pilot.script.done else
                                       "; ".join(e for e in pilot.script.events if "FAILED" in e))
        verdict = f"FAILED: reached {reached}/{len(legs)} pads: {why}"
    _picture(options.out / PATH_IMAGE, finder, legs, truth, arena,
             f"{scenario}, arena {arena.name}, seed {options.seed}: {verdict}")
    report = {
        "scenario": scenario, "arena": arena.name, "seed": options.seed,
        "random_arena": options.random_arena, "start_pad": arena.start_pad,
        "verdict": verdict, "ok": ok, "crashed": crash is not None,
        "crash": None if crash is None else {"reason": crash.reason,
                                             "t_s": rounded(crash.t_s, 3)},
        "legs": leg_reports, "pads_reached": reached, "pads_total": len(legs),
        "rmse_m": rmse, "sim_time_s": rounded(result.sim_time_s, 3),
        "map_points": len(mapping.map), "graph_builds": finder.graph_builds,
        "graph_updates": finder.graph_updates, "graph_unchanged": finder.graph_unchanged,
        "plan_requests": finder.requests,
        "map_file": save_map_to, "path_image": PATH_IMAGE,
        "host": {"wall_time_s": rounded(result.wall_time_s, 2),
                 "real_time_factor": rounded(result.real_time_factor, 2)},
    }
    if options.faults:
        report["faults"] = judge_flight(options.faults, failsafes, truth, arena,
                                        sitl.scene.quad.leg_height, crash)
    write_report(options.out, report)
    return report


def _picture(path: Any, finder: PathFinderNode, legs: list[Leg], truth: Trajectory,
             arena: ArenaSpec, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 7.5))
    graph = None
    try:
        graph = finder.graph()
    except NavigationError:  # a picture without the map is still a picture
        graph = None
    if graph is not None:
        k = int((CRUISE_ALTITUDE - graph.grid.origin[2]) / graph.grid.resolution)
        blocked = ~graph.free[:, :, k]
        x0, y0, _ = graph.grid.origin
        nx, ny, _ = graph.grid.shape
        r = graph.grid.resolution
        ax.imshow(blocked.T, origin="lower", cmap="Greys", alpha=0.5, vmin=0, vmax=1.5,
                  extent=(x0, x0 + nx * r, y0, y0 + ny * r))
    for o in arena.obstacles:
        cx, cy = o.center
        sx, sy, h = o.size
        ax.add_patch(plt.Rectangle((cx - sx / 2, cy - sy / 2), sx, sy, fill=False,
                                   ec="red" if h > CRUISE_ALTITUDE else "orange", lw=1))
    for p in arena.pads:
        ax.plot(*p.center, "s", color="deepskyblue", ms=8)
        ax.annotate(str(p.id), p.center, fontsize=8, ha="center", va="center")
    for i, leg in enumerate(legs):
        if leg.planned is not None and len(leg.planned):
            ax.plot(leg.planned[:, 0], leg.planned[:, 1], "-", color="green", lw=1.2,
                    label="planned" if i == 0 else None)
    if len(truth):
        ax.plot(truth.position[:, 0], truth.position[:, 1], "-", color="blue", lw=0.7,
                label="flown")
    start = arena.pad(arena.start_pad).center
    ax.plot(*start, "o", color="blue", ms=9, label="start")
    ax.set_xlim(0, arena.field.size[0])
    ax.set_ylim(0, arena.field.size[1])
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def navigate(options: ScenarioOptions) -> dict[str, Any]:
    """``--scenario navigate``: see the module docstring."""
    arena = options.load_arena()
    return fly_legs(options, arena, scenario="navigate")


def map_arena(options: ScenarioOptions) -> dict[str, Any]:
    """``--scenario map-arena``: the navigate flight, saving the depth map as map.pcd (load
    it with the path finder's ``map_file`` to plan on an offline graph)."""
    arena = options.load_arena()
    return fly_legs(options, arena, scenario="map-arena", save_map_to=MAP_FILE)


__all__ = ["CRUISE_ALTITUDE", "NavigatePilot", "fly_legs", "leg_order", "map_arena",
           "navigate"]
