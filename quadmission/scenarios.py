"""Scenarios that ``quadmission sim --scenario NAME`` runs, each writing a report.

A scenario is a function of :class:`ScenarioOptions` that writes ``report.json`` (and
pictures) into ``options.out`` and returns the report. The registry maps names to them;
later capabilities add theirs (the contest mission). Each report carries a one-line
``verdict`` for a person; progress goes to ``options.progress`` (the CLI prints it on
stderr).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2

from quadmission.errors import OptionsError
from quadmission.mission import mission_scenario
from quadmission.navigate_flight import map_arena, navigate
from quadmission.precision_landing import precision_landing
from quadmission.report import write_report
from quadmission.square_flight import square
from runtime import DeterministicExecutor, Node, qos_profile_sensor_data
from sim.arena import ArenaSpec, Lighting, default_arena, dump_arena, load_arena
from sim.arena_generator import generate_arena
from sim.markers import detect_markers
from sim.quadrotor import MotorModel
from sim.render import Image, SceneRenderer
from sim.scene import place_quadrotor
from sim.sensors import DOWN_IMAGE_TOPIC, SimSensorsNode, image_from_msg, sensor_parts
from sim.world import Actuation, ConstantThrust, RobotMotion, Scene, run_world

ARENA_NAME = "arena.yaml"  # every run writes the arena it flew here
TOUR_HEIGHT = 1.5  # m, camera height above each pad in the arena tour


@dataclass(frozen=True)
class ScenarioOptions:
    """What every scenario takes: where to write, the seed, the arena, and where progress
    lines go (default: nowhere)."""

    out: Path
    seed: int = 0
    arena: Path | None = None  # None: config/arenas/contest.yaml
    random_arena: bool = False  # generate an arena from the seed instead
    lighting: Lighting | None = None  # None: the arena file's preset
    target_robot: int | None = None  # mission: the robot to find (None: config/mission.yaml)
    remove_pad: int | None = None  # mission: take this pad out of the field (seed 003, 4.2)
    progress: Callable[[str], None] = field(default=lambda _line: None, compare=False)
    # pacing, recording, Foxglove, the operator page (quadmission.run_services.RunServices)
    services: Any = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.random_arena and self.arena is not None:
            raise OptionsError(f"give an arena file ({self.arena}) or a random arena, not both")

    def load_arena(self) -> ArenaSpec:
        """The arena this run flies, with the lighting option applied. It is also written
        to ``out/arena.yaml``, so anyone can replay the run or recompute its errors."""
        if self.random_arena:
            arena = generate_arena(self.seed)
        else:
            arena = load_arena(self.arena) if self.arena else default_arena()
        if self.lighting is not None:
            arena = replace(arena, lighting=self.lighting)
        self.out.mkdir(parents=True, exist_ok=True)
        (self.out / ARENA_NAME).write_text(dump_arena(arena))
        return arena


Scenario = Callable[[ScenarioOptions], dict[str, Any]]


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
            options.progress(f"  pad {pad.id:2d} at ({x:5.2f}, {y:5.2f}): decoded {decoded}")
    decoded_count = sum(1 for p in pads if p["decoded"])
    report = {
        "scenario": "arena-tour",
        "verdict": f"decoded {decoded_count}/{len(pads)} pads",
        "arena": arena.name,
        "seed": options.seed,
        "camera_height_m": TOUR_HEIGHT,
        "pads": pads,
        "pads_decoded": decoded_count,
        "pads_total": len(pads),
        "all_decoded": all(p["decoded"] for p in pads),
        "arena_image": "arena.png",
    }
    write_report(options.out, report)
    return report


SCENARIOS: dict[str, Scenario] = {
    "arena-tour": arena_tour,
    "map-arena": map_arena,
    "mission": mission_scenario,
    "navigate": navigate,
    "precision-landing": precision_landing,
    "square": square,
}
#: The most complete scenario there is; ``make sim`` runs it.
DEFAULT_SCENARIO = "mission"
