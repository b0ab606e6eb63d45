"""Scanner node overhead: the aruco_scanner node (message in, detection and measurement,
MarkerDetectionArray out, delivered) against a bare ``ArucoDetector.detectMarkers`` on
the same frames, in the same run.

Frames: the down camera over each pad of the contest arena at 1.5 m, through the camera
sensor model (light). Writes per-frame milliseconds and the ratio to ``--out`` (default
benchmarks/results/scanner_overhead.json).

Also the STRETCH pass (the scanner's costly one: it runs on every frame where the first
pass finds nothing, most frames of a mission) with its measured 3 adaptive windows
against the 6 it had, on frames over the pads and over empty floor, light and dark:
milliseconds per frame and markers read, each.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import cv2

from perception.aruco import ArucoScanner, Preprocess, ScanMode, ScannerSettings
from perception.aruco_scanner_node import MARKERS_TOPIC, ArucoScannerNode
from runtime import DeterministicExecutor, Node, Time, qos_profile_default, qos_profile_sensor_data
from sim.arena import Lighting, default_arena
from sim.camera_model import CameraSensorModel, camera_model_params
from sim.render import CameraIntrinsics, SceneRenderer
from sim.scene import place_quadrotor
from sim.sensors import DOWN_FRAME, DOWN_IMAGE_TOPIC, DOWN_INFO_TOPIC, camera_info_msg, image_msg
from sim.world import Scene


class _Feeder(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("feeder", **kwargs)
        self.image = self.create_publisher("sensor_msgs/msg/Image", DOWN_IMAGE_TOPIC,
                                           qos_profile_sensor_data)
        self.info = self.create_publisher("sensor_msgs/msg/CameraInfo", DOWN_INFO_TOPIC,
                                          qos_profile_sensor_data)
        self.received = 0
        self.create_subscription("quadmission_interfaces/msg/MarkerDetectionArray",
                                 MARKERS_TOPIC, self._on, qos_profile_default)

    def _on(self, _msg: Any) -> None:
        self.received += 1


def stretch_pass(repeats: int) -> dict[str, object]:
    """The STRETCH pass alone, 6 windows (3-53 px, before) vs 3 (13-33 px, now)."""
    variants = {"windows_3_53": ScannerSettings(passes=(Preprocess.STRETCH,), stretch_win_min=3,
                                                stretch_win_max=53),
                "windows_13_33": ScannerSettings(passes=(Preprocess.STRETCH,))}
    out: dict[str, object] = {}
    for lighting in (Lighting.LIGHT, Lighting.DARK):
        arena = replace(default_arena(), lighting=lighting)
        scene = Scene.build(arena)
        sensor = CameraSensorModel(camera_model_params(), lighting, 0)
        frames = []
        with SceneRenderer(scene.model) as renderer:
            for pad in arena.pads:  # over the pad, and 2 m beside it (floor, obstacles)
                for dx in (0.0, 2.0):
                    place_quadrotor(scene.model, scene.data, scene.index,
                                    (pad.center[0] + dx, pad.center[1], 1.5))
                    frames.append(sensor.apply(renderer.down_image(scene.data)))
        row: dict[str, object] = {"frames": len(frames)}
        for name, settings in variants.items():
            scanner = ArucoScanner(settings)
            t0 = time.perf_counter()
            for _ in range(repeats):
                read = sum(len(scanner.find(f, ScanMode.BOTH)) for f in frames)
            row[name] = {"ms_per_frame": round(1000 * (time.perf_counter() - t0)
                                               / (repeats * len(frames)), 2), "markers": read}
        out[lighting.value] = row
    return out


def run(repeats: int) -> dict[str, object]:
    arena = default_arena()
    scene = Scene.build(arena)
    intrinsics = CameraIntrinsics.from_camera(scene.quad.down_camera)
    sensor = CameraSensorModel(camera_model_params(), arena.lighting, 0)
    frames = []
    with SceneRenderer(scene.model) as renderer:
        for pad in arena.pads:
            place_quadrotor(scene.model, scene.data, scene.index, (*pad.center, 1.5))
            frames.append(sensor.apply(renderer.down_image(scene.data)))
    detector = cv2.aruco.ArucoDetector(
        cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_7X7_1000),
        cv2.aruco.DetectorParameters())
    t0 = time.perf_counter()
    for _ in range(repeats):
        for f in frames:
            detector.detectMarkers(cv2.cvtColor(f, cv2.COLOR_RGB2GRAY))
    bare = (time.perf_counter() - t0) / (repeats * len(frames))
    ex = DeterministicExecutor()
    ex.add_node(ArucoScannerNode(context=ex.context))
    feeder = _Feeder(context=ex.context)
    ex.add_node(feeder)
    ex.spin_for(0.01)
    msgs = [image_msg(f, Time(0), DOWN_FRAME) for f in frames]
    info = camera_info_msg(intrinsics, Time(0), DOWN_FRAME)
    t0 = time.perf_counter()
    for _ in range(repeats):
        for m in msgs:
            feeder.info.publish(info)
            feeder.image.publish(m)
            ex.spin_for(0.001)
    node = (time.perf_counter() - t0) / (repeats * len(frames))
    return {"benchmark": "scanner_overhead", "frames": len(frames) * repeats,
            "delivered": feeder.received, "bare_detect_ms": round(1000 * bare, 2),
            "node_ms": round(1000 * node, 2), "ratio_node_over_bare": round(node / bare, 2),
            "stretch_pass": stretch_pass(repeats)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path,
                        default=Path(__file__).parent / "results" / "scanner_overhead.json")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    result = run(args.repeats)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
