"""The simulated visual odometry: its parameters come from config/sim_vision.yaml."""

from __future__ import annotations

from pathlib import Path

import pytest

from runtime import DeterministicExecutor
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
