"""Scenarios that ``quadmission sim --scenario NAME`` runs, each writing a report.

A scenario is a function of :class:`ScenarioOptions` that writes ``report.json`` (and
pictures) into ``options.out`` and returns the report. The registry maps names to them;
later capabilities add theirs (the square flight, the contest mission).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from runtime import DeterministicExecutor, Node, qos_profile_sensor_data
from sim.arena import ArenaSpec, default_arena, load_arena
from sim.arena_generator import generate_arena
from sim.markers import detect_markers
from sim.quadrotor import MotorModel
from sim.render import Image, SceneRenderer
from sim.scene import place_quadrotor
from sim.sensors import DOWN_IMAGE_TOPIC, SimSensorsNode, image_from_msg, sensor_parts
from sim.world import Actuation, ConstantThrust, RobotMotion, Scene, StopWhen, run_world

TOUR_HEIGHT = 1.5  # m, camera height above each pad in the arena tour


@dataclass(frozen=True)
class ScenarioOptions:
    """What every scenario takes: where to write, the seed, and the arena."""

    out: Path
    seed: int = 0
    arena: Path | None = None  # None: config/arenas/contest.yaml
    random_arena: bool = False  # generate an arena from the seed instead

    def load_arena(self) -> ArenaSpec:
        if self.random_arena:
            return generate_arena(self.seed)
        return load_arena(self.arena) if self.arena else default_arena()


Scenario = Callable[[ScenarioOptions], dict[str, Any]]


def _progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def write_report(out: Path, report: dict[str, Any]) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    path = out / "report.json"
    path.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return path


def save_png(path: Path, rgb: Image) -> None:
    if not cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
        raise OSError(f"could not write {path}")


class _FrameGrabber(Node):
    """Keeps the latest downward camera frame, as any companion node would get it."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("frame_grabber", **kwargs)
        self.latest: Image | None = None
        self.create_subscription("sensor_msgs/msg/Image", DOWN_IMAGE_TOPIC, self._on_image,
                                 qos_profile_sensor_data)

    def _on_image(self, msg: Any) -> None:
        self.latest = image_from_msg(msg)


def arena_tour(options: ScenarioOptions) -> dict[str, Any]:
    """Picture the arena from above, hover over each pad, and decode its marker from the
    downward camera topic. Writes arena.png, pad_<id>.png and report.json."""
    options.out.mkdir(parents=True, exist_ok=True)
    arena = options.load_arena()
    scene = Scene.build(arena)
    ex = DeterministicExecutor()
    sensors = SimSensorsNode(context=ex.context)
    grabber = _FrameGrabber(context=ex.context)
    ex.add_node(sensors)
    ex.add_node(grabber)
    pads: list[dict[str, Any]] = []
    with SceneRenderer(scene.model) as renderer:
        save_png(options.out / "arena.png", renderer.top_view(scene.data))
        parts = [Actuation(ConstantThrust.hover(scene.quad), MotorModel.hovering(scene.quad)),
                 RobotMotion(), *sensor_parts(sensors, renderer, scene, seed=options.seed)]
        for pad in arena.pads:
            x, y = pad.center
            place_quadrotor(scene.model, scene.data, scene.index, (x, y, TOUR_HEIGHT))
            grabber.latest = None
            run_world(scene, ex, duration_s=1.0 / 12.0, parts=parts)
            if grabber.latest is None:
                raise RuntimeError(f"pad {pad.id}: no frame arrived on {DOWN_IMAGE_TOPIC}")
            image_name = f"pad_{pad.id}.png"
            save_png(options.out / image_name, grabber.latest)
            decoded = sorted(detect_markers(grabber.latest))
            pads.append({"id": pad.id, "center": [x, y], "decoded_ids": decoded,
                         "decoded": decoded == [pad.id], "image": image_name})
            _progress(f"  pad {pad.id:2d} at ({x:5.2f}, {y:5.2f}): decoded {decoded}")
    report = {
        "scenario": "arena-tour",
        "arena": arena.name,
        "seed": options.seed,
        "camera_height_m": TOUR_HEIGHT,
        "pads": pads,
        "pads_decoded": int(np.sum([p["decoded"] for p in pads])),
        "pads_total": len(pads),
        "all_decoded": all(p["decoded"] for p in pads),
        "arena_image": "arena.png",
    }
    write_report(options.out, report)
    return report




# -- the square flight (the simulated flight controller) -----------------------------------

SQUARE_SIDE = 4.0  # m
SQUARE_ALTITUDE = 1.5  # m


def _path_plot(out: Path, reference_enu: np.ndarray, actual_enu: np.ndarray,
               arena: ArenaSpec) -> None:
    """Top-down plot of the commanded (blue) and flown (red) paths, 100 px per metre."""
    scale, margin = 100, 60
    lo = np.minimum(reference_enu.min(axis=0), actual_enu.min(axis=0))[:2] - 0.5
    hi = np.maximum(reference_enu.max(axis=0), actual_enu.max(axis=0))[:2] + 0.5
    size = ((hi - lo) * scale).astype(int) + 2 * margin
    image = np.full((size[1], size[0], 3), 255, dtype=np.uint8)

    def px(p: np.ndarray) -> tuple[int, int]:
        x, y = (p[:2] - lo) * scale + margin
        return int(x), int(size[1] - y)

    for path, colour in ((reference_enu, (200, 80, 0)), (actual_enu, (0, 0, 220))):
        points = np.array([px(p) for p in path], dtype=np.int32)
        cv2.polylines(image, [points], False, colour, 2, cv2.LINE_AA)
    cv2.putText(image, "setpoint", (10, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (200, 80, 0), 2)
    cv2.putText(image, "flown", (10, 44), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 220), 2)
    cv2.putText(image, f"1 m = {scale} px, ENU, arena {arena.name}", (10, size[1] - 12),
                cv2.FONT_HERSHEY_SIMPLEX, 0.5, (60, 60, 60), 1)
    if not cv2.imwrite(str(out), image):
        raise OSError(f"could not write {out}")


def square(options: ScenarioOptions) -> dict[str, Any]:
    """Arm, enter offboard through a test harness streaming px4 setpoints, fly a 4 m
    square at 1.5 m, land and disarm. Writes report.json and path.png."""
    from flight_control.frames import ned_to_enu
    from quadmission.offboard_harness import HarnessPhase, OffboardHarness
    from sim.fcu.link import LinkDirection
    from sim.fcu.sitl import build_sitl

    options.out.mkdir(parents=True, exist_ok=True)
    arena = options.load_arena()
    sitl = build_sitl(arena, seed=options.seed)
    side = SQUARE_SIDE
    harness = OffboardHarness(
        [[side, 0.0, 0.0], [side, side, 0.0], [0.0, side, 0.0], [0.0, 0.0, 0.0]],
        altitude=SQUARE_ALTITUDE, context=sitl.executor.context)
    sitl.executor.add_node(harness)

    class _Progress:
        name, rate_hz = "progress", 1.0
        last = None

        def update(self, t_ns: int, scene: Scene) -> None:
            if harness.phase is not self.last:
                _progress(f"  t={t_ns / 1e9:6.1f} s  {harness.phase.value}")
                self.last = harness.phase

    sitl.extra_parts.append(_Progress())
    result = sitl.run(180.0, stop=StopWhen(lambda: harness.done))
    traj = result.trajectory
    started = harness.phase_started_ns
    fly_ref = [(t, p) for t, p in harness.reference
               if HarnessPhase.FLY in started and HarnessPhase.LAND in started
               and started[HarnessPhase.FLY] <= t < started[HarnessPhase.LAND]]
    path_image = None
    if fly_ref:
        t_ref = np.array([t for t, _ in fly_ref]) / 1e9
        ref_enu = ned_to_enu(np.array([p for _, p in fly_ref]))
        actual = np.column_stack([np.interp(t_ref, traj.t, traj.position[:, i])
                                  for i in range(3)])
        err = actual - ref_enu
        rmse = {axis: float(np.sqrt(np.mean(err[:, i] ** 2))) for i, axis in enumerate("xyz")}
        path_image = "path.png"
        _path_plot(options.out / path_image, ref_enu, traj.position, arena)
    else:
        rmse = {axis: float("nan") for axis in "xyz"}
    report = {
        "scenario": "square",
        "arena": arena.name,
        "seed": options.seed,
        "side_m": side,
        "altitude_m": SQUARE_ALTITUDE,
        "completed": harness.done,
        "final_phase": harness.phase.value,
        "crashed": result.crash is not None,
        "crash": None if result.crash is None else result.crash.reason,
        "tracking_rmse_m": rmse,
        "sim_time_s": result.sim_time_s,
        "wall_time_s": result.wall_time_s,
        "rtf": result.real_time_factor,
        "fcu_overruns": sitl.firmware.scheduler.report().overruns,
        "link": {d.name.lower(): {"sent": c.sent, "lost": c.lost, "spikes": c.spikes}
                 for d in LinkDirection for c in [sitl.link.counters(d)]},
        "path_image": path_image,
        "ok": harness.done and result.crash is None,
    }
    write_report(options.out, report)
    return report


SCENARIOS: dict[str, Scenario] = {
    "arena-tour": arena_tour,
    "square": square,
}
#: The most complete scenario there is; ``make sim`` runs it.
DEFAULT_SCENARIO = "square"
