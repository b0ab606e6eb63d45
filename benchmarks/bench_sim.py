"""Simulator speed: physics steps per second and the cost of one downward camera frame.

    python benchmarks/bench_sim.py --out benchmarks/results/sim.json

Each figure is measured next to its baseline in the same run:
- physics: our world loop (hover actuation through the motor model, robots moving,
  crash detector, trajectory recorder, executor in lockstep, no camera) against a bare
  ``mujoco.mj_step`` loop on the same model; the ratio is the world loop's overhead.
- camera: one downward frame rendered, wrapped in a sensor_msgs/Image, serialized,
  published and delivered to a subscriber, against a bare ``mujoco.Renderer.render()``
  of the same camera, at 640x480 and 320x240.
"""

from __future__ import annotations

import os
import statistics
import time
from dataclasses import replace
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
from _harness import bench_parser, write_result

from interfaces import graph
from runtime import DeterministicExecutor, Node, qos_profile_sensor_data
from sim.arena import default_arena
from sim.mjcf import DOWN_CAMERA, QUAD_GEOM_GROUP
from sim.quadrotor import MotorModel, QuadrotorParams
from sim.render import CameraIntrinsics, SceneRenderer
from sim.sensors import DownCamera, SimSensorsNode
from sim.world import Actuation, ConstantThrust, RobotMotion, Scene, run_world


def bench_physics(sim_seconds: float) -> dict[str, Any]:
    arena = default_arena()
    scene = Scene.build(arena)
    scene.place_at_takeoff(height=1.0)
    parts = [Actuation(ConstantThrust.hover(scene.quad), MotorModel.hovering(scene.quad)),
             RobotMotion()]
    result = run_world(scene, DeterministicExecutor(config_dir=None), duration_s=sim_seconds,
                       parts=parts)
    ours = result.physics_steps / result.wall_time_s

    bare = Scene.build(arena)
    bare.place_at_takeoff(height=1.0)
    bare.data.ctrl[:] = bare.quad.hover_thrust
    steps = result.physics_steps
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(bare.model, bare.data)
    baseline = steps / (time.perf_counter() - start)
    return {
        "physics_hz": scene.physics_hz,
        "sim_seconds": sim_seconds,
        "world_loop_steps_per_s": round(ours),
        "bare_mj_step_steps_per_s": round(baseline),
        "ratio_world_over_bare": round(ours / baseline, 3),
        "real_time_factor_no_camera": round(result.real_time_factor, 1),
    }


def bench_camera(width: int, height: int, frames: int) -> dict[str, Any]:
    default = QuadrotorParams()
    quad = replace(default, down_camera=replace(default.down_camera, width=width, height=height))
    scene = Scene.build(default_arena(), quad)
    scene.place_at_takeoff(height=1.5)
    ex = DeterministicExecutor()  # the sensors node reads config/sim_sensors.yaml
    node = SimSensorsNode(context=ex.context)
    received: list[int] = []
    Node("viewer", context=ex.context).create_subscription(
        "sensor_msgs/msg/Image", graph.CAMERA_DOWN_RAW.name, lambda m: received.append(m.width),
        qos_profile_sensor_data)
    with SceneRenderer(scene.model) as renderer:
        camera = DownCamera(node, renderer, CameraIntrinsics.from_camera(quad.down_camera),
                            rate_hz=node.params.down_camera.rate_hz)
        camera.update(0, scene)  # warm up the GL context
        ex.spin_until(0)
        ours = []
        for i in range(frames):
            start = time.perf_counter()
            camera.update(i, scene)
            ex.spin_until(i)
            ours.append(time.perf_counter() - start)

        bare = mujoco.Renderer(scene.model, height=height, width=width)
        option = mujoco.MjvOption()
        option.geomgroup[QUAD_GEOM_GROUP] = 0
        base = []
        for _ in range(frames):
            start = time.perf_counter()
            bare.update_scene(scene.data, camera=DOWN_CAMERA, scene_option=option)
            bare.render()
            base.append(time.perf_counter() - start)
        bare.close()
    assert len(received) == frames + 1
    ours_ms = statistics.median(ours) * 1e3
    base_ms = statistics.median(base) * 1e3
    return {
        "size": f"{width}x{height}",
        "frames": frames,
        "render_publish_deliver_ms": round(ours_ms, 2),
        "bare_render_ms": round(base_ms, 2),
        "ratio_ours_over_bare": round(ours_ms / base_ms, 3),
    }


def main(argv: list[str] | None = None) -> int:
    parser = bench_parser(__doc__, "sim")
    parser.add_argument("--sim-seconds", type=float, default=10.0)
    parser.add_argument("--frames", type=int, default=40)
    args = parser.parse_args(argv)
    report = {
        "physics": bench_physics(args.sim_seconds),
        "camera": [bench_camera(640, 480, args.frames), bench_camera(320, 240, args.frames)],
    }
    print(write_result(args.out, report), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
