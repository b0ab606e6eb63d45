"""Scanner node overhead: the aruco_scanner node (message in, detection and measurement,
MarkerDetectionArray out, delivered) against a bare ``ArucoDetector.detectMarkers`` on
the same frames, in the same run.

Frames: the down camera over each pad of the contest arena at 1.5 m, through the camera
sensor model (light). Writes per-frame milliseconds and the ratio to ``--out`` (default
benchmarks/results/scanner_overhead.json).

The halved search (``ScannerSettings.half_res_min_side_px``): on frames over random arenas'
pads and robots, light and dark, at the robot search's height (1.9 m), the cruise height
(1.5 m) and lower, the markers the scanner
reads at full resolution against halved (the node's floor at each height, from the height
plus its margin), the corner differences and the milliseconds per frame, each.

Also the STRETCH pass (the scanner's costly one: it runs on every frame where the first
pass finds nothing, most frames of a mission) with its measured 3 adaptive windows
against the 6 it had, on frames over the pads and over empty floor, light and dark:
milliseconds per frame and markers read, each.
"""

from __future__ import annotations

import itertools
import json
import time
from dataclasses import replace
from typing import Any

import cv2
from _harness import bench_parser, write_result

from interfaces import graph
from perception.aruco import ArucoScanner, Preprocess, ScanMode, ScannerSettings, to_grey
from perception.aruco_scanner_node import ArucoScannerNode
from runtime import DeterministicExecutor, Node, Time, qos_profile_default, qos_profile_sensor_data
from sim.arena import Lighting, default_arena
from sim.camera_model import CameraSensorModel, camera_model_params
from sim.render import CameraIntrinsics, SceneRenderer
from sim.scene import place_quadrotor, set_robot_poses
from sim.sensors import DOWN_FRAME, camera_info_msg, image_msg
from sim.world import Scene


class _Feeder(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("feeder", **kwargs)
        self.image = self.create_publisher("sensor_msgs/msg/Image", graph.CAMERA_DOWN_RAW.name,
                                           qos_profile_sensor_data)
        self.info = self.create_publisher("sensor_msgs/msg/CameraInfo", graph.CAMERA_DOWN_INFO.name,
                                          qos_profile_sensor_data)
        self.received = 0
        self.create_subscription("quadmission_interfaces/msg/MarkerDetectionArray",
                                 graph.PERCEPTION_MARKERS.name, self._on, qos_profile_default)

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


def half_resolution(arena_seeds: range, repeats: int) -> dict[str, object]:
    """Full resolution against halved, the mission's passes, the node's floor at each
    height: markers read, corner differences [px], ms per frame (see the docstring)."""
    import numpy as np

    from fsm.params import MissionParams
    from perception.params import ScannerParams
    from runtime.parameters import load_parameters
    from sim.arena_generator import generate_arena

    params = load_parameters(ScannerParams, "aruco_scanner")
    settings = params.scanner_settings()
    full = ArucoScanner(replace(settings, half_res_min_side_px=0.0))
    halved = ArucoScanner(settings)
    # over each pad and robot: straight above, and off to a side or a corner of the frame
    offsets = ((0.0, 0.0), (0.9, 0.0), (0.0, -0.7), (-0.8, 0.6))
    mission = load_parameters(MissionParams, "mission")
    # m: the robot search's height, the cruise height, a lower pass
    heights = (mission.explore_altitude, mission.cruise_altitude, 1.2)
    out: dict[str, object] = {"arena_seeds": [arena_seeds.start, arena_seeds.stop - 1],
                              "heights_m": list(heights), "min_side_px": {}}
    for lighting in (Lighting.LIGHT, Lighting.DARK):
        frames: list[tuple[Any, float]] = []
        frame_heights: list[float] = []
        for seed in arena_seeds:
            arena = replace(generate_arena(seed), lighting=lighting)
            scene = Scene.build(arena)
            sensor = CameraSensorModel(camera_model_params(), lighting, seed)
            intrinsics = CameraIntrinsics.from_camera(scene.quad.down_camera)
            targets = [p.center for p in arena.pads] + [r.path[0] for r in arena.robots]
            with SceneRenderer(scene.model) as renderer:
                set_robot_poses(scene.data, scene.index, arena, 0.0)
                for (x, y), (dx, dy), h in itertools.product(targets, offsets, heights):
                    place_quadrotor(scene.model, scene.data, scene.index, (x + dx, y + dy, h))
                    floor = params.min_side_px(ScanMode.BOTH, intrinsics.fy,
                                               h + params.height_margin_m)
                    frames.append((to_grey(sensor.apply(renderer.down_image(scene.data))),
                                   floor))
                    frame_heights.append(h)
        read: dict[str, list[dict[int, Any]]] = {}
        ms: dict[str, float] = {}
        for name, scanner in (("full", full), ("halved", halved)):
            t0 = time.perf_counter()
            for _ in range(repeats):
                read[name] = [scanner.find(g, ScanMode.BOTH, min_side_px=f) for g, f in frames]
            ms[name] = 1000 * (time.perf_counter() - t0) / (repeats * len(frames))
        pairs = list(zip(read["full"], read["halved"], strict=True))
        diffs = [float(np.abs(a[i] - b[i]).max()) for a, b in pairs for i in a.keys() & b.keys()]
        out[lighting.value] = {
            "frames": len(frames),
            "markers_full": sum(map(len, read["full"])),
            "markers_halved": sum(map(len, read["halved"])),
            "lost_by_halving": sum(len(a.keys() - b.keys()) for a, b in pairs),
            "gained_by_halving": sum(len(b.keys() - a.keys()) for a, b in pairs),
            "frames_halved": sum(f >= settings.half_res_min_side_px for _, f in frames),
            "corner_diff_px": {"p50": round(float(np.median(diffs)), 3),
                               "p95": round(float(np.percentile(diffs, 95)), 3),
                               "max": round(max(diffs), 3)},
            "ms_per_frame": {k: round(v, 2) for k, v in ms.items()},
            "ratio_halved_over_full": round(ms["halved"] / ms["full"], 2),
            "per_height": {f"{h} m": {
                "frames": sum(fh == h for fh in frame_heights),
                "markers_full": sum(len(a) for (a, _), fh in zip(pairs, frame_heights,
                                                                strict=True) if fh == h),
                "markers_halved": sum(len(b) for (_, b), fh in zip(pairs, frame_heights,
                                                                  strict=True) if fh == h)}
                for h in heights}}
        out["min_side_px"] = {f"{h} m": round(params.min_side_px(
            ScanMode.BOTH, intrinsics.fy, h + params.height_margin_m), 1) for h in heights}
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
    scanner = ArucoScannerNode(context=ex.context)
    ex.add_node(scanner)
    feeder = _Feeder(context=ex.context)
    ex.add_node(feeder)
    ex.spin_for(0.01)
    msgs = [image_msg(f, Time(0), DOWN_FRAME) for f in frames]
    info = camera_info_msg(intrinsics, Time(0), DOWN_FRAME)
    # each frame until its markers are out: the scan's processing time in simulated time
    # (the executor waits for the scan's thread, no longer), then the delivery
    per_frame_s = scanner.params.processing_s + 0.001
    t0 = time.perf_counter()
    for _ in range(repeats):
        for m in msgs:
            feeder.info.publish(info)
            feeder.image.publish(m)
            ex.spin_for(per_frame_s)
    node = (time.perf_counter() - t0) / (repeats * len(frames))
    return {"benchmark": "scanner_overhead", "frames": len(frames) * repeats,
            "delivered": feeder.received, "bare_detect_ms": round(1000 * bare, 2),
            "node_ms": round(1000 * node, 2), "ratio_node_over_bare": round(node / bare, 2),
            "stretch_pass": stretch_pass(repeats),
            "half_resolution": half_resolution(range(100, 110), repeats)}


def main() -> None:
    parser = bench_parser(__doc__, "scanner_overhead")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    result = run(args.repeats)
    write_result(args.out, result)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
