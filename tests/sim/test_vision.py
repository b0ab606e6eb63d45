"""The simulated visual odometry: its parameters come from config/sim_vision.yaml."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from runtime import DeterministicExecutor, qos_profile_sensor_data
from runtime.errors import ParameterError
from runtime.parameters import config_path, load_parameters
from sim.vision import VisionNode, VisionNoise, VisionParams, VisionPose


def test_the_node_holds_the_parameters_of_its_config_file() -> None:
    node = VisionNode(context=DeterministicExecutor().context)
    assert node.params == load_parameters(VisionParams, "sim_vision")
    part = VisionPose.from_node(node)
    assert (part.rate_hz, part.noise) == (node.params.rate_hz, node.params.noise)
    assert VisionPose.from_node(node, noise=VisionNoise.zero()).noise.position_std == 0.0


def test_a_bad_noise_value_names_the_file_and_the_key(tmp_path: Path) -> None:
    text = config_path("sim_vision.yaml").read_text(encoding="utf-8")
    bad = tmp_path / "sim_vision.yaml"
    bad.write_text(text.replace("position_std: 0.01", "position_std: -0.01"), encoding="utf-8")
    with pytest.raises(ParameterError) as caught:
        VisionNode(context=DeterministicExecutor(config_dir=tmp_path).context)
    assert str(caught.value) == (
        f"{bad}: sim_vision.noise.position_std: -0.01 is outside the allowed range [0, 1] m")


def test_the_noise_is_the_per_update_normal_draws() -> None:
    """Drawing a block of updates' normals at once gives, bit for bit, what one
    ``rng.normal`` call per term and update gave (drift step, white noise, yaw)."""
    from sim.arena import default_arena
    from sim.world import Scene

    scene = Scene.build(default_arena())
    scene.place_at_takeoff(1.0)
    executor = DeterministicExecutor()
    node = VisionNode(context=executor.context)
    noise = VisionNoise(position_std=0.01, yaw_std=0.005, drift_rate=0.002, latency_s=0.0)
    part = VisionPose(node, noise, rate_hz=30.0, seed=4)
    seen: list[tuple[float, float, float]] = []
    node.create_subscription("geometry_msgs/msg/PoseWithCovarianceStamped",
                             "/sim/vision/pose",
                             lambda m: seen.append((m.pose.pose.position.x,
                                                    m.pose.pose.position.y,
                                                    m.pose.pose.orientation.z)),
                             qos_profile_sensor_data)
    rng = np.random.default_rng(4)
    drift = np.zeros(3)
    truth = scene.data.qpos[:7].copy()
    for k in range(300):  # across the block boundary
        t_ns = k * 33_333_333
        part.update(t_ns, scene)
        executor.spin_until(t_ns)
        drift += rng.normal(0.0, noise.drift_rate * math.sqrt(1.0 / 30.0), 3)
        position = truth[:3] + drift + rng.normal(0.0, noise.position_std, 3)
        half = float(rng.normal(0.0, noise.yaw_std)) / 2.0
        w, z = float(truth[3]), float(truth[6])
        want = (float(position[0]), float(position[1]),
                math.cos(half) * z + math.sin(half) * w)
        assert seen[-1] == want, f"update {k}"
