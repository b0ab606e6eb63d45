"""The ``arena-tour`` scenario: picture the arena from above, hover over each pad and decode
its marker from the downward camera topic."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2

from interfaces import graph
from quadmission.reports.report import write_report
from quadmission.scenarios.options import ScenarioOptions
from runtime import DeterministicExecutor, Node
from sim.markers import detect_markers
from sim.quadrotor import MotorModel
from sim.render import Image, SceneRenderer
from sim.scene import place_quadrotor
from sim.sensors import SimSensorsNode, image_from_msg, sensor_parts
from sim.world import Actuation, ConstantThrust, RobotMotion, Scene, run_world

__all__ = ["TOUR_HEIGHT", "arena_tour", "save_png"]

TOUR_HEIGHT = 1.5  # m, camera height above each pad in the arena tour


def save_png(path: Path, rgb: Image) -> None:
    if not cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
        raise OSError(f"could not write {path}")


class _FrameGrabber(Node):
    """Keeps the latest downward camera frame, as any companion node would get it."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("frame_grabber", **kwargs)
        self.latest: Image | None = None
        image = graph.CAMERA_DOWN_RAW
        self.create_subscription(image.type, image.name, self._on_image, image.subscriber_qos)

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
                raise RuntimeError(f"pad {pad.id}: no frame arrived on "
                                   f"{graph.CAMERA_DOWN_RAW.name}")
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
