"""The ``precision-landing`` scenario: one precision landing per pad, judged from truth.

Each episode is a fresh SITL flight: the vehicle stands on the floor beside the pad,
0.3-1.0 m off its centre in a seeded direction and clear of obstacles, walls and robot
corridors; the companion (bridge, VIO, flight control, the ArUco scanner on the
downward camera, the precision-land action) is started; a mission script
(:class:`~quadmission.scenarios.precision_landing.pilot.LandingPilot`) arms, takes off to the search
altitude and asks ``/navigation/precision_land`` for the pad, telling it where the pad
should be (the contest map). Where the vehicle came to rest is read from the simulator
here, and only here.

``report.json``: ``landings`` (``pad``, ``touchdown_xy_m``, ``touchdown_error_m``,
``inside_pad``, ``duration_s``, the action's result), ``rmse_m``, ``max_error_m``,
``all_inside``, ``crashed``; ``touchdowns.png`` draws each touchdown over its pad.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from navigation.mapping_node import MappingNode
from navigation.path_finder_node import PathFinderNode
from navigation.precision_land_node import PrecisionLandNode
from perception.aruco_scanner_node import ArucoScannerNode
from quadmission.assembly.companion import planning_bounds, start_companion
from quadmission.assembly.faults import check_faults, judge_flight
from quadmission.evaluation.faults import FcuFailsafes
from quadmission.reports.report import write_report
from quadmission.scenarios.precision_landing.pilot import LandingPilot
from sim.arena import (
    DRONE_CLEARANCE,
    PAD_MARKER_SIZE,
    PAD_SIZE,
    PAD_THICKNESS,
    ROBOT_RADIUS,
    ArenaSpec,
    Pad,
)
from sim.fault_spec import Fault, FaultKind
from sim.faults import install_faults
from sim.fcu.sitl import build_sitl
from sim.geometry import segment_distance
from sim.render import SceneRenderer
from sim.scene import place_quadrotor, quad_state
from sim.sensors import SimSensorsNode, sensor_parts
from sim.world import StopWhen, Trajectory

if TYPE_CHECKING:
    from quadmission.scenarios.options import ScenarioOptions

SEARCH_ALTITUDE = 1.5  # m, take-off altitude of each episode (above the take-off point)
START_OFFSET = (0.3, 1.0)  # m, start distance from the pad centre
EPISODE_LIMIT_S = 200.0  # s of simulated time per episode
SETTLE_S = 1.0  # s flown after the action ends, so the vehicle comes to rest
PICTURE = "touchdowns.png"


def start_position(arena: ArenaSpec, pad: Pad, rng: np.random.Generator) -> tuple[float, float]:
    """A seeded start beside ``pad``: 0.3-1.0 m from its centre, the drone's footprint
    (``DRONE_CLEARANCE``) clear of obstacles, walls and robot corridors."""
    size_x, size_y, _ = arena.field.size
    cx, cy = pad.center
    for _ in range(500):
        r = rng.uniform(*START_OFFSET)
        a = rng.uniform(0.0, 2.0 * math.pi)
        x, y = cx + r * math.cos(a), cy + r * math.sin(a)
        if not (DRONE_CLEARANCE <= x <= size_x - DRONE_CLEARANCE
                and DRONE_CLEARANCE <= y <= size_y - DRONE_CLEARANCE):
            continue
        if any(o.footprint.inflated(DRONE_CLEARANCE).contains_point((x, y))
               for o in arena.obstacles):
            continue
        if any(segment_distance((x, y), (x, y), a0, b0) < ROBOT_RADIUS + DRONE_CLEARANCE
               for robot in arena.robots for a0, b0 in robot.segments()):
            continue
        return x, y
    raise RuntimeError(f"pad {pad.id}: no clear start 0.3-1.0 m from its centre")


@dataclass
class _Episode:
    pad: Pad
    start_xy: tuple[float, float]
    touchdown_xy: tuple[float, float] | None
    crash: str | None
    success: bool
    message: str
    result_code: int | None
    duration_s: float | None
    faults: list[dict[str, Any]] | None = None
    trajectory: Trajectory | None = None  # ground truth, for evaluation


def fly_episode(arena: ArenaSpec, pad: Pad, start_xy: tuple[float, float], *, seed: int,
                landing_overrides: dict[str, Any] | None = None,
                faults: Sequence[Fault] = (), mapped: bool = False,
                search_radius: float = 0.0) -> _Episode:
    """One precision landing on ``pad`` from ``start_xy`` through the companion stack,
    with ``faults`` (times from the episode's start). ``mapped``: the mapping node and the
    path finder fly too (the depth camera on), so the pad search checks its legs on the
    live map, as in a mission; ``search_radius`` [m]: the goal's (0: the node's)."""
    sitl = build_sitl(arena, seed=seed)
    scene = sitl.scene
    z = PAD_THICKNESS + scene.quad.leg_height
    place_quadrotor(scene.model, scene.data, scene.index, (start_xy[0], start_xy[1], z))
    start_companion(sitl)
    context = sitl.executor.context
    sensors = SimSensorsNode(context=context)
    scanner = ArucoScannerNode(context=context, parameter_overrides={"mode": "pads"})
    lander = PrecisionLandNode(context=context, parameter_overrides=landing_overrides or {})
    pilot = LandingPilot(pad.id, (pad.center[0], pad.center[1], 0.0), altitude=SEARCH_ALTITUDE,
                         search_radius=search_radius, context=context)
    mapping = MappingNode(context=context) if mapped else None
    finder = (PathFinderNode(context=context, parameter_overrides=planning_bounds(arena))
              if mapped else None)
    for node in (sensors, scanner, lander, pilot, mapping, finder):
        if node is not None:
            sitl.executor.add_node(node)
    with SceneRenderer(scene.model) as renderer:
        cameras = ("down_camera", "depth_camera") if mapped else ("down_camera",)
        # the depth camera renders only as often as the mapping node fuses clouds
        depth_hz = None if mapping is None else mapping.params.process_rate_hz
        parts = [p for p in sensor_parts(sensors, renderer, scene, seed=seed, depth_hz=depth_hz)
                 if p.name in cameras]
        sitl.extra_parts.extend(parts)
        failsafes = FcuFailsafes(sitl.firmware)
        if faults:  # an episode without faults keeps the parts it had
            install_faults(sitl, faults, sensors=sensors)
            sitl.extra_parts.append(failsafes)
        result = sitl.run(EPISODE_LIMIT_S, stop=StopWhen(lambda: pilot.done))
        crash = result.crash
        flights = [result.trajectory]
        if result.crash is None and pilot.done:
            result = sitl.run(SETTLE_S)
            crash = result.crash
            flights.append(result.trajectory)
    # the whole episode's truth: each run records its own
    truth = Trajectory(*(np.concatenate([getattr(t, f.name) for t in flights])
                         for f in fields(Trajectory)))
    state = quad_state(scene.data, scene.index)
    outcome = pilot.outcome
    landed = crash is None and outcome is not None and outcome.success
    duration = None
    if outcome is not None and outcome.land_started_ns is not None \
            and outcome.land_ended_ns is not None:
        duration = (outcome.land_ended_ns - outcome.land_started_ns) / 1e9
    message = (f"crash: {crash.reason} at {crash.t_s:.1f} s" if crash is not None
               else outcome.message if outcome is not None
               else f"not finished after {EPISODE_LIMIT_S:g} s (step {pilot.step})")
    judged = None
    if faults:
        ended_s = result.sim_time_s if outcome is None or outcome.land_ended_ns is None \
            else outcome.land_ended_ns / 1e9
        skipped = [] if landed else [(ended_s, pad.id, message)]
        judged = judge_flight(faults, failsafes, truth, arena,
                              scene.quad.leg_height, crash, skipped)
    return _Episode(pad, start_xy,
                    (float(state.position[0]), float(state.position[1])) if landed else None,
                    None if crash is None else crash.reason, landed, message,
                    None if outcome is None else outcome.result_code, duration, judged, truth)


def _r(value: float | None, digits: int = 4) -> float | None:
    return None if value is None else round(float(value), digits)


def landing_json(e: _Episode) -> dict[str, Any]:
    error = None
    inside = False
    if e.touchdown_xy is not None:
        dx, dy = e.touchdown_xy[0] - e.pad.center[0], e.touchdown_xy[1] - e.pad.center[1]
        error = math.hypot(dx, dy)
        inside = abs(dx) <= PAD_SIZE / 2.0 and abs(dy) <= PAD_SIZE / 2.0
    return {"pad": e.pad.id, "pad_xy_m": list(e.pad.center),
            "start_xy_m": [_r(v) for v in e.start_xy],
            "touchdown_xy_m": None if e.touchdown_xy is None else [_r(v) for v in e.touchdown_xy],
            "touchdown_error_m": _r(error), "inside_pad": inside,
            "duration_s": _r(e.duration_s, 2), "landed": e.success, "crash": e.crash,
            "result_code": e.result_code, "message": e.message,
            **({} if e.faults is None else {"faults": e.faults})}


def summary(landings: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """RMSE and max of the touchdown errors, over the episodes that landed."""
    errors = [d["touchdown_error_m"] for d in landings if d["touchdown_error_m"] is not None]
    return {
        "rmse_m": _r(math.sqrt(sum(e * e for e in errors) / len(errors))) if errors else None,
        "max_error_m": _r(max(errors)) if errors else None,
        "landed": sum(1 for d in landings if d["landed"]),
        "all_inside": bool(landings) and all(d["inside_pad"] for d in landings),
        "crashed": any(d["crash"] is not None for d in landings),
    }


def save_touchdowns(path: Path, title: str, landings: Sequence[dict[str, Any]]) -> None:
    """One small top view per pad: the pad, its marker, the start and the touchdown."""
    n = max(1, len(landings))
    cols = min(5, n)
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(3.0 * cols, 3.2 * rows + 0.6))
    FigureCanvasAgg(fig)
    fig.suptitle(title)
    half = PAD_SIZE / 2.0
    for i, d in enumerate(landings):
        ax = fig.add_subplot(rows, cols, i + 1)
        ax.add_patch(Rectangle((-half, -half), PAD_SIZE, PAD_SIZE, color="lightskyblue"))
        m = PAD_MARKER_SIZE / 2.0
        ax.add_patch(Rectangle((-m, -m), PAD_MARKER_SIZE, PAD_MARKER_SIZE, fill=False,
                               edgecolor="k"))
        cx, cy = d["pad_xy_m"]
        sx, sy = d["start_xy_m"]
        ax.plot([sx - cx], [sy - cy], "o", color="0.5", label="start")
        if d["touchdown_xy_m"] is not None:
            tx, ty = d["touchdown_xy_m"]
            colour = "tab:green" if d["inside_pad"] else "tab:red"
            ax.plot([tx - cx], [ty - cy], "x", color=colour, markersize=10, mew=2,
                    label="touchdown")
            ax.set_title(f"pad {d['pad']}: {100 * d['touchdown_error_m']:.1f} cm", fontsize=9)
        else:
            ax.set_title(f"pad {d['pad']}: not landed", fontsize=9, color="tab:red")
        ax.set_xlim(-1.1, 1.1)
        ax.set_ylim(-1.1, 1.1)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
        ax.grid(True, lw=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def run_landings(options: ScenarioOptions, arena: ArenaSpec, pads: Sequence[Pad], *,
                 landing_overrides: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Fly one episode per pad; the landings as reported."""
    check_faults("precision-landing", options.faults)
    landings = []
    for pad in pads:
        rng = np.random.default_rng([options.seed, pad.id])
        start = start_position(arena, pad, rng)
        # an occluded pad is that pad's episode's fault only
        faults = [f for f in options.faults if f.kind is not FaultKind.PAD_OCCLUDED
                  or int(f.value("pad")) == pad.id]
        episode = fly_episode(arena, pad, start, seed=options.seed * 1000 + pad.id,
                              landing_overrides=landing_overrides, faults=faults)
        d = landing_json(episode)
        landings.append(d)
        err = d["touchdown_error_m"]
        options.progress(f"  pad {pad.id:2d}: " + (
            f"{100 * err:.1f} cm, {'inside' if d['inside_pad'] else 'OUTSIDE'}, "
            f"{d['duration_s']:.0f} s" if err is not None else f"FAILED: {d['message']}"))
    return landings


def precision_landing(options: ScenarioOptions) -> dict[str, Any]:
    """Land on every pad of the arena, one episode each; write report.json and
    touchdowns.png into ``options.out``."""
    arena = options.load_arena()
    return write_landing_report(options, arena, run_landings(options, arena, arena.pads))


def write_landing_report(options: ScenarioOptions, arena: ArenaSpec,
                         landings: list[dict[str, Any]]) -> dict[str, Any]:
    """report.json and touchdowns.png of the landings flown (one per pad, in pad order)."""
    s = summary(landings)
    verdict = (f"{s['landed']}/{len(landings)} landed, "
               f"{sum(d['inside_pad'] for d in landings)} inside the pad, "
               + ("RMSE n/a" if s["rmse_m"] is None else
                  f"RMSE {s['rmse_m']:.3f} m, max {s['max_error_m']:.3f} m"))
    if s["crashed"]:
        verdict = "CRASH: " + verdict
    report = {"scenario": "precision-landing", "verdict": verdict, "arena": arena.name,
              "seed": options.seed, "random_arena": options.random_arena,
              "lighting": arena.lighting.value, "landings": landings, **s,
              "ok": s["all_inside"] and not s["crashed"], "picture": PICTURE}
    save_touchdowns(options.out / PICTURE, f"precision landing, arena {arena.name}, "
                    f"{arena.lighting.value}, seed {options.seed}: {verdict}", landings)
    write_report(options.out, report)
    return report


__all__ = ["fly_episode", "landing_json", "precision_landing", "run_landings",
           "start_position", "summary", "write_landing_report"]
