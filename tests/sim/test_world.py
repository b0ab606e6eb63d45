"""The world loop: lockstep with the executor, rates checked, crashes, replay, sensors, and
its tuning from config/sim_world.yaml."""

from __future__ import annotations

import math
import shutil
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from interfaces import graph
from runtime import DeterministicExecutor, Node, qos_profile_sensor_data
from runtime.clock import seconds_to_ns
from runtime.errors import ParameterError
from runtime.parameters import CONFIG_DIR_ENV, PACKAGE_CONFIG_DIR
from sim.arena import ArenaSpec, default_arena
from sim.quadrotor import MotorModel
from sim.render import SceneRenderer
from sim.scene import place_quadrotor
from sim.sensors import (
    DownCamera,
    SimSensorsNode,
    image_from_msg,
    points_from_msg,
    sensor_parts,
)
from sim.world import (
    Actuation,
    ConstantThrust,
    CrashDetector,
    Imu,
    MotorsOff,
    RateError,
    RobotMotion,
    Scene,
    WorldResult,
    WorldStatus,
    run_world,
    world_params,
)


@pytest.fixture(scope="module")
def contest() -> ArenaSpec:
    return default_arena()


def _hover_parts(scene: Scene) -> list[Any]:
    return [Actuation(ConstantThrust.hover(scene.quad), MotorModel.hovering(scene.quad))]


def test_hover_thrust_holds_the_vehicle_for_ten_seconds(contest: ArenaSpec) -> None:
    scene = Scene.build(contest)
    scene.place_at_takeoff(height=1.0)
    ex = DeterministicExecutor(config_dir=None)
    result = run_world(scene, ex, duration_s=10.0, parts=_hover_parts(scene))
    assert result.status is WorldStatus.COMPLETED and result.crash is None
    assert result.sim_time_s == pytest.approx(10.0)
    drift = np.linalg.norm(result.trajectory.position - result.trajectory.position[0], axis=1)
    assert drift.max() < 1e-3
    assert ex.now().seconds == pytest.approx(10.0)  # the executor kept in lockstep
    assert len(result.trajectory) == 1000  # 100 Hz over [0, 10) s


def test_a_drop_from_height_is_a_crash(contest: ArenaSpec) -> None:
    scene = Scene.build(contest)
    scene.place_at_takeoff(height=2.0)
    result = run_world(scene, DeterministicExecutor(config_dir=None), duration_s=5.0,
                       parts=[Actuation(MotorsOff(), MotorModel(scene.quad))])
    assert result.status is WorldStatus.CRASHED
    assert result.crash is not None and result.crash.reason.startswith("touchdown at")
    assert result.crash.t_s == pytest.approx(0.6, abs=0.1)  # sqrt(2 * 2 m / g)


def test_a_torque_imbalance_flips_the_vehicle_and_is_a_crash(contest: ArenaSpec) -> None:
    scene = Scene.build(contest)
    scene.place_at_takeoff(height=2.0)
    lopsided = ConstantThrust(0.0)
    lopsided.commands = lambda t_ns, s: np.array([9.0, 0.0, 9.0, 0.0])  # type: ignore[method-assign]
    result = run_world(scene, DeterministicExecutor(config_dir=None), duration_s=3.0,
                       parts=[Actuation(lopsided, MotorModel.hovering(scene.quad))])
    assert result.status is WorldStatus.CRASHED
    assert result.crash is not None and "tilt" in result.crash.reason


def test_landing_on_an_obstacle_is_a_crash_that_names_it(contest: ArenaSpec) -> None:
    scene = Scene.build(contest)
    box = contest.obstacles[0]
    top = box.height + scene.quad.leg_height + 0.05
    place_quadrotor(scene.model, scene.data, scene.index, (*box.center, top))
    result = run_world(scene, DeterministicExecutor(config_dir=None), duration_s=1.0,
                       parts=[Actuation(MotorsOff(), MotorModel(scene.quad))])
    assert result.status is WorldStatus.CRASHED
    assert result.crash is not None and result.crash.reason == "hit obstacle_0"
    assert result.crash.position[:2] == pytest.approx(box.center, abs=1e-3)


def test_parts_run_at_every_multiple_of_their_period_across_runs(contest: ArenaSpec) -> None:
    """Each part runs at every multiple of its period, in the order given; runs that end
    between updates (7 steps, then 20 at a time) continue the one run's schedule."""

    def runs(durations_steps: list[int]) -> list[tuple[int, str]]:
        scene = Scene.build(contest)
        scene.place_at_takeoff(height=1.0)
        ex = DeterministicExecutor(config_dir=None)
        log: list[tuple[int, str]] = []

        class Log:
            def __init__(self, name: str, rate_hz: float) -> None:
                self.name, self.rate_hz = name, rate_hz

            def update(self, t_ns: int, s: Scene) -> None:
                log.append((t_ns, self.name))

        parts = [*_hover_parts(scene), Log("a", 500.0), Log("b", 30.0), Log("c", 50.0),
                 Log("d", 1500.0)]
        for steps in durations_steps:
            result = run_world(scene, ex, duration_s=steps / scene.physics_hz, parts=parts)
            assert result.physics_steps == steps
        return log

    one = runs([300])
    assert one == runs([7, *[20] * 14, 13])
    rates = {"a": 500, "b": 30, "c": 50, "d": 1500}
    want = sorted([((k * 1500 // rate) * 10**9 // 1500, name)
                   for name, rate in rates.items() for k in range(rate * 300 // 1500)],
                  key=lambda row: (row[0], "abcd".index(row[1])))
    assert one == want


def test_a_rate_that_does_not_divide_physics_is_refused(contest: ArenaSpec) -> None:
    scene = Scene.build(contest, physics_hz=500)
    with pytest.raises(RateError, match=r"robots: 7\.0 Hz does not divide the physics rate 500"):
        run_world(scene, DeterministicExecutor(config_dir=None), duration_s=1.0,
                  parts=[RobotMotion(rate_hz=7.0)])


def _recorded_run(contest: ArenaSpec, seed: int) -> tuple[Any, list[bytes], Any]:
    scene = Scene.build(contest)
    scene.place_at_takeoff(height=1.0)
    ex = DeterministicExecutor()  # the sensors node reads config/sim_sensors.yaml
    node = SimSensorsNode(context=ex.context)
    listener = Node("listener", context=ex.context)
    clouds: list[bytes] = []
    listener.create_subscription("sensor_msgs/msg/PointCloud2", graph.CAMERA_DEPTH_POINTS.name,
                                 lambda m: clouds.append(points_from_msg(m).tobytes()),
                                 qos_profile_sensor_data)
    with SceneRenderer(scene.model) as renderer:
        parts = [*_hover_parts(scene), RobotMotion(),
                 *sensor_parts(node, renderer, scene, seed=seed, depth_hz=2.0)]
        result = run_world(scene, ex, duration_s=1.0, parts=parts)
    robots = scene.data.mocap_pos.copy()
    return result, clouds, robots


def test_the_same_seed_gives_the_same_run(contest: ArenaSpec) -> None:
    a, clouds_a, robots_a = _recorded_run(contest, seed=3)
    b, clouds_b, robots_b = _recorded_run(contest, seed=3)
    _, clouds_c, _ = _recorded_run(contest, seed=4)
    assert np.array_equal(a.trajectory.position, b.trajectory.position)
    assert np.array_equal(a.trajectory.quaternion, b.trajectory.quaternion)
    assert clouds_a == clouds_b and len(clouds_a) == 2  # 2 Hz over [0, 1) s
    assert clouds_c != clouds_a  # the noise really is seeded
    assert np.array_equal(robots_a, robots_b)
    initial = Scene.build(contest).data.mocap_pos
    assert not np.allclose(robots_a, initial)  # the robots moved


def test_cameras_publish_at_their_rate_only_while_subscribed(contest: ArenaSpec) -> None:
    scene = Scene.build(contest)
    scene.place_at_takeoff(height=1.0)
    ex = DeterministicExecutor()  # the sensors node reads config/sim_sensors.yaml
    node = SimSensorsNode(context=ex.context)
    with SceneRenderer(scene.model) as renderer:
        parts = sensor_parts(node, renderer, scene)
        camera = parts[0]
        run_world(scene, ex, duration_s=0.5, parts=[*_hover_parts(scene), *parts])
        assert camera.frames_rendered == 0  # nobody listening: nothing rendered

        listener = Node("listener", context=ex.context)
        frames: list[tuple[int, Any]] = []

        def on_image(msg: Any) -> None:
            stamp_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            frames.append((stamp_ns, image_from_msg(msg)))
            # stamped at its exposure, seen the configured latency later
            assert ex.now().nanoseconds - stamp_ns == seconds_to_ns(camera.latency_s)

        listener.create_subscription("sensor_msgs/msg/Image", graph.CAMERA_DOWN_RAW.name, on_image,
                                     qos_profile_sensor_data)
        run_world(scene, ex, duration_s=1.0, parts=[*_hover_parts(scene), *parts])
    assert len(frames) == 12
    stamps = np.diff([s for s, _ in frames])
    assert np.all(np.abs(stamps - 1e9 / 12) < 1.0)
    assert frames[0][1].shape == (480, 640, 3)


def _down_frames(contest: ArenaSpec, latency_s: float) -> list[tuple[int, int, bytes]]:
    """(seen at, stamp, pixels) of the down camera's frames over 1 s of a climb, with the
    sensor model, its latency set to ``latency_s``."""
    scene = Scene.build(contest)
    scene.place_at_takeoff(height=1.0)
    ex = DeterministicExecutor()
    node = SimSensorsNode(context=ex.context)
    frames: list[tuple[int, int, bytes]] = []

    def on_image(msg: Any) -> None:
        stamp_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        frames.append((ex.now().nanoseconds, stamp_ns, image_from_msg(msg).tobytes()))

    Node("listener", context=ex.context).create_subscription(
        "sensor_msgs/msg/Image", graph.CAMERA_DOWN_RAW.name, on_image, qos_profile_sensor_data)
    with SceneRenderer(scene.model) as renderer:
        camera = sensor_parts(node, renderer, scene, seed=5)[0]
        assert isinstance(camera, DownCamera)
        camera.latency_s = latency_s
        thrust = ConstantThrust(scene.quad.hover_thrust * 1.1)  # climbing: the view changes
        run_world(scene, ex, duration_s=1.0,
                  parts=[Actuation(thrust, MotorModel.hovering(scene.quad)), camera])
    return frames


def test_a_camera_with_latency_renders_on_a_thread_and_publishes_the_same_frames_later(
        contest: ArenaSpec) -> None:
    """The render thread draws the scene captured at the exposure: every frame, sensor
    noise included, is the in-line frame, published 50 ms later (simulated time)."""
    in_line = _down_frames(contest, 0.0)
    later = _down_frames(contest, 0.05)
    assert len(in_line) == len(later) == 12  # the last is seen at 0.967 s
    assert [f[1:] for f in later] == [f[1:] for f in in_line]
    assert all(seen - stamp == 50_000_000 for seen, stamp, _ in later)
    assert all(seen == stamp for seen, stamp, _ in in_line)
    assert len({pixels for _, _, pixels in in_line}) == 12  # the view changes: a real test
    assert _down_frames(contest, 0.05) == later  # and runs repeat


def test_a_frame_in_flight_is_dropped_when_the_sensors_node_is_destroyed(
        contest: ArenaSpec) -> None:
    scene = Scene.build(contest)
    scene.place_at_takeoff(height=1.0)
    ex = DeterministicExecutor()
    node = SimSensorsNode(context=ex.context)
    seen: list[Any] = []
    Node("listener", context=ex.context).create_subscription(
        "sensor_msgs/msg/Image", graph.CAMERA_DOWN_RAW.name, seen.append, qos_profile_sensor_data)
    with SceneRenderer(scene.model) as renderer:
        camera = sensor_parts(node, renderer, scene)[0]
        assert isinstance(camera, DownCamera)
        camera.latency_s = 0.05
        run_world(scene, ex, duration_s=0.01, parts=[camera])  # one exposure, at 0 s
        node.destroy_node()
        ex.spin_for(1.0)  # its delivery time passes: nothing published, nothing raised
    assert camera.frames_rendered == 1 and seen == []


def test_imu_reads_gravity_at_rest_with_seeded_noise(contest: ArenaSpec) -> None:
    def run(seed: int) -> tuple[Any, Any]:
        scene = Scene.build(contest)
        scene.place_at_takeoff()
        samples: list[Any] = []
        imu = Imu.seeded(seed, rate_hz=500.0)  # the firmware's IMU rate

        class Tap:
            name, rate_hz = "tap", 500.0

            def update(self, t_ns: int, s: Scene) -> None:
                samples.append(np.concatenate([imu.latest.accel, imu.latest.gyro]))

        run_world(scene, DeterministicExecutor(config_dir=None), duration_s=1.0,
                  parts=[Actuation(MotorsOff(), MotorModel(scene.quad)), imu, Tap()])
        data = np.array(samples[10:])
        return data, imu.noise.accel_bias

    data, accel_bias = run(1)
    mean = data.mean(axis=0)
    assert mean[2] == pytest.approx(9.81 + accel_bias[2], abs=0.02)  # standing: +g on z
    assert np.all(np.abs(mean[3:]) < 0.02)  # not rotating (gyro bias ~5 mrad/s)
    assert data[:, 0].std() > 0.01  # there is noise
    again, _ = run(1)
    other, _ = run(2)
    assert np.array_equal(data, again) and not np.array_equal(data, other)


def test_the_imu_sample_as_arrays_is_made_from_its_floats_when_read(contest: ArenaSpec) -> None:
    scene = Scene.build(contest)
    scene.place_at_takeoff()
    imu = Imu.seeded(1, rate_hz=500.0)
    assert imu.latest is None and imu.latest_values is None
    imu.update(0, scene)
    first = imu.latest
    assert first is not None and imu.latest is first  # made once per sample
    assert (*first.accel.tolist(), *first.gyro.tolist()) == imu.latest_values
    imu.update(2_000_000, scene)
    again = imu.latest
    assert again is not None and again is not first
    assert (*again.accel.tolist(), *again.gyro.tolist()) == imu.latest_values


# -- the world's tuning comes from config/sim_world.yaml --------------------------------------


def _config_with(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, old: str,
                 new: str) -> Path:
    """A copy of the config folder, ``old`` replaced by ``new`` in ``name``, made current."""
    folder = tmp_path / "config"
    if not folder.exists():
        shutil.copytree(PACKAGE_CONFIG_DIR, folder)
    path = folder / name
    text = path.read_text(encoding="utf-8")
    assert old in text, f"{old!r} not in {name}"
    path.write_text(text.replace(old, new), encoding="utf-8")
    monkeypatch.setenv(CONFIG_DIR_ENV, str(folder))
    return path


def _tilted(scene: Scene, tilt_deg: float) -> Scene:
    """The quadrotor 1 m above the start pad, rolled by ``tilt_deg``, at rest."""
    scene.place_at_takeoff(height=1.0)
    half = math.radians(tilt_deg) / 2.0
    adr = scene.index.qpos_adr
    scene.data.qpos[adr + 3: adr + 7] = (math.cos(half), math.sin(half), 0.0, 0.0)
    mujoco.mj_forward(scene.model, scene.data)
    return scene


def test_the_world_runs_at_the_rates_of_its_config_file(
        contest: ArenaSpec, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _config_with(tmp_path, monkeypatch, "sim_world.yaml", "trajectory_rate_hz: 100.0",
                 "trajectory_rate_hz: 40.0")
    _config_with(tmp_path, monkeypatch, "sim_world.yaml", "physics_hz: 1500", "physics_hz: 1000")
    scene = Scene.build(contest)
    scene.place_at_takeoff(height=1.0)
    result = run_world(scene, DeterministicExecutor(config_dir=None), duration_s=1.0,
                       parts=_hover_parts(scene))
    assert scene.model.opt.timestep == pytest.approx(1e-3)
    assert result.physics_steps == 1000
    assert len(result.trajectory) == 40  # 40 Hz over [0, 1) s
    assert RobotMotion().rate_hz == 50.0 and Actuation(MotorsOff(), MotorModel(scene.quad)
                                                       ).rate_hz == 500.0  # the file's
    assert RobotMotion(rate_hz=25.0).rate_hz == 25.0  # a rate given in code wins
    assert Scene.build(contest, physics_hz=500).physics_hz == 500


def test_the_crash_tilt_comes_from_config(
        contest: ArenaSpec, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    scene = _tilted(Scene.build(contest), 45.0)
    default = CrashDetector()
    default.update(0, scene)
    assert default.crash is None  # 45 deg is within the shipped 80 deg

    _config_with(tmp_path, monkeypatch, "sim_world.yaml", "max_tilt_deg: 80.0",
                 "max_tilt_deg: 30.0")
    strict = CrashDetector()
    assert strict.params == world_params().crash
    strict.update(0, scene)
    assert strict.crash is not None and strict.crash.reason == "tilt 45 deg"

    lenient = CrashDetector(replace(strict.params, max_tilt_deg=60.0))  # an override in code
    lenient.update(0, scene)
    assert lenient.crash is None


def test_the_touchdown_speed_comes_from_config(
        contest: ArenaSpec, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def drop() -> WorldResult:  # from 0.3 m: between 1.5 and 3 m/s at touchdown
        scene = Scene.build(contest)
        scene.place_at_takeoff(height=0.3)
        return run_world(scene, DeterministicExecutor(config_dir=None), duration_s=1.0,
                         parts=[Actuation(MotorsOff(), MotorModel(scene.quad))])

    hard = drop()
    assert hard.crash is not None and hard.crash.reason.startswith("touchdown at")
    speed = float(hard.crash.reason.split()[2])
    assert 1.5 < speed < 3.0  # over the shipped limit, under the one below
    _config_with(tmp_path, monkeypatch, "sim_world.yaml", "max_touchdown_speed: 1.5",
                 "max_touchdown_speed: 3.0")
    soft = drop()
    assert soft.status is WorldStatus.COMPLETED and soft.crash is None


@pytest.mark.parametrize(("old", "new", "message"), [
    ("robots_rate_hz: 50.0", "robots_rate_hz: 7.0",
     "sim_world.robots_rate_hz: 7 Hz does not divide the physics rate 1500 Hz (physics_hz)"),
    ("  rate_hz: 500.0", "  rate_hz: 2000.0",
     "sim_world.crash.rate_hz: 2000 Hz does not divide the physics rate 1500 Hz (physics_hz)"),
    ("physics_hz: 1500", "physics_hz: 1501",
     "sim_world.actuation_rate_hz: 500 Hz does not divide the physics rate 1501 Hz "
     "(physics_hz)"),
    ("max_tilt_deg: 80.0", "max_tilt_deg: 0.0",
     "sim_world.crash.max_tilt_deg: 0.0 is outside the allowed range (0, 180] deg"),
])
def test_a_bad_world_config_names_the_file_and_the_key(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, old: str, new: str,
        message: str) -> None:
    path = _config_with(tmp_path, monkeypatch, "sim_world.yaml", old, new)
    with pytest.raises(ParameterError) as caught:
        RobotMotion()
    assert str(caught.value) == f"{path}: {message}"
