"""The simulated sensors' tuning: rates and noise from the sim_sensors node's section of
config/sim_sensors.yaml, the onboard cameras from its sim_cameras section."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from runtime import DeterministicExecutor
from runtime.errors import ParameterError
from runtime.parameters import CONFIG_DIR_ENV, PACKAGE_CONFIG_DIR, load_parameters
from sim.arena import ArenaSpec
from sim.quadrotor import QuadrotorParams, onboard_cameras
from sim.render import SceneRenderer
from sim.sensors import (
    ClockPublisher,
    DepthCamera,
    DownCamera,
    SensorParams,
    SimSensorsNode,
    sensor_parts,
)
from sim.world import Scene


def _config_copy(tmp_path: Path, old: str, new: str) -> Path:
    """A copy of the config folder with ``old`` replaced by ``new`` in sim_sensors.yaml."""
    folder = tmp_path / "config"
    shutil.copytree(PACKAGE_CONFIG_DIR, folder)
    path = folder / "sim_sensors.yaml"
    text = path.read_text(encoding="utf-8")
    assert old in text, f"{old!r} not in sim_sensors.yaml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def test_the_sensor_parts_run_at_the_node_s_configured_rates(arena: ArenaSpec) -> None:
    scene = Scene.build(arena)
    node = SimSensorsNode(context=DeterministicExecutor().context)
    assert node.params == load_parameters(SensorParams, "sim_sensors")
    with SceneRenderer(scene.model) as renderer:
        down, depth, clock = sensor_parts(node, renderer, scene)
        assert isinstance(down, DownCamera) and isinstance(depth, DepthCamera)
        assert isinstance(clock, ClockPublisher)
        assert (down.rate_hz, depth.rate_hz, clock.rate_hz) == (
            node.params.down_camera.rate_hz, node.params.depth_camera.rate_hz,
            node.params.clock_rate_hz)
        given = sensor_parts(node, renderer, scene, camera_hz=6.0, depth_hz=2.0)
        assert (given[0].rate_hz, given[1].rate_hz) == (6.0, 2.0)  # given in code: wins


def test_a_configured_rate_that_does_not_divide_the_physics_rate_names_the_key(
        arena: ArenaSpec, tmp_path: Path) -> None:
    path = _config_copy(tmp_path, "rate_hz: 12.0", "rate_hz: 7.0")
    node = SimSensorsNode(context=DeterministicExecutor(config_dir=path.parent).context)
    scene = Scene.build(arena, physics_hz=3000)
    with SceneRenderer(scene.model) as renderer, pytest.raises(ParameterError) as caught:
        sensor_parts(node, renderer, scene)
    assert str(caught.value) == (
        "sim_sensors.down_camera.rate_hz: 7 Hz does not divide the physics rate 3000 Hz")


def test_a_bad_depth_noise_names_the_file_and_the_key(tmp_path: Path) -> None:
    path = _config_copy(tmp_path, "noise_std: 0.01", "noise_std: -0.01")
    with pytest.raises(ParameterError) as caught:
        SimSensorsNode(context=DeterministicExecutor(config_dir=path.parent).context)
    assert str(caught.value) == (
        f"{path}: sim_sensors.depth_camera.noise_std: -0.01 is outside the allowed range "
        "[0, 1] m")


def test_the_down_camera_resolution_comes_from_config(
        arena: ArenaSpec, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert (QuadrotorParams().down_camera.width, QuadrotorParams().down_camera.height) == (
        640, 480)  # the shipped file
    path = _config_copy(tmp_path, "width: 640                  # px, [1, 4096]\n"
                                  "      height: 480", "width: 320\n      height: 240")
    monkeypatch.setenv(CONFIG_DIR_ENV, str(path.parent))
    quad = QuadrotorParams()
    assert quad.down_camera == onboard_cameras().down_camera
    assert (quad.down_camera.width, quad.down_camera.height) == (320, 240)
    scene = Scene.build(arena)
    with SceneRenderer(scene.model) as renderer:
        assert renderer.down_image(scene.data).shape == (240, 320, 3)


def test_a_camera_that_sees_nothing_names_the_file_and_the_key(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = _config_copy(tmp_path, "far: 10.0 ", "far: 0.05 ")
    monkeypatch.setenv(CONFIG_DIR_ENV, str(path.parent))
    with pytest.raises(ParameterError) as caught:
        QuadrotorParams()
    assert str(caught.value) == (
        f"{path}: sim_cameras.depth_camera.far: 0.05 must be beyond near (0.1)")
