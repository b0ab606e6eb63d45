"""A start pad facing open floor (issue 39, item 6): nothing within the depth camera's range
is a map too, free space as far as it sees, so the preflight passes, the vehicle takes
off and the exploration starts.

Before, the mapping published nothing while its map held no voxel, the path finder said
"no map yet" and the preflight stopped the mission after 10 s, in the light and the dark.
The flight is cut after its first exploration legs: a whole mission on this arena is a
few minutes of simulated flight (flown by hand: ``quadmission sim --arena FILE``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from fsm.params import MissionParams
from navigation.mapping import camera_to_map
from navigation.params import MappingParams
from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.mission.scenario import fly_mission
from runtime.parameters import load_parameters
from sim.arena import load_arena
from sim.render import DepthPointCloud, SceneRenderer
from sim.world import Scene

pytestmark = pytest.mark.slow

# A 12 x 8 m field. The vehicle starts on pad 1 facing east (+x): the nearest thing ahead,
# the robot's track at x = 8.5 m and the pillar at x = 9 m, is beyond the mapping's 6 m
# range; the block at the north-west corner is behind the camera until the survey turn.
ARENA = """\
name: open-start
lighting: light
field:
  size: [12.0, 8.0, 4.0]
  wall_thickness: 0.2
start_pad: 1
obstacles:
  - {center: [9.5, 1.8], size: [1.0, 1.0, 3.0]}
  - {center: [10.0, 6.5], size: [1.2, 0.8, 0.8]}
  - {center: [1.0, 6.9], size: [1.0, 1.0, 3.0]}
pads:
  - {id: 1, center: [1.5, 4.0]}
  - {id: 2, center: [10.5, 4.0]}
  - {id: 3, center: [5.5, 1.5]}
robots:
  - marker_id: 19
    speed: 0.2
    loop: false
    path: [[8.5, 4.5], [8.5, 6.5]]
    points: {1: 10, 2: 30, 3: 20}
"""


@pytest.fixture(scope="module")
def arena_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("arena") / "open_start.yaml"
    path.write_text(ARENA)
    return path


def test_the_start_pad_sees_nothing_the_map_keeps(arena_file: Path) -> None:
    """The premise, from the simulator's truth: the depth camera on the start pad sees
    the floor and what lies beyond the mapping's range, nothing the map keeps."""
    scene = Scene.build(load_arena(arena_file))
    scene.place_at_takeoff()
    mujoco.mj_forward(scene.model, scene.data)
    with SceneRenderer(scene.model) as renderer:
        seen = DepthPointCloud(renderer, scene.quad.depth_camera, noise_std=0.0).points(
            scene.data)
    assert len(seen) > 0  # the camera sees the floor...
    mp = load_parameters(MappingParams, "mapping")
    body = np.asarray(scene.data.qpos[scene.index.qpos_adr:scene.index.qpos_adr + 7])
    kept = camera_to_map(seen, body[:3], body[3:], mp.depth_camera_position,
                         min_range=mp.min_range, max_range=mp.max_range)
    assert not (kept[:, 2] >= mp.min_z).any()  # ...and nothing the map would hold


@pytest.fixture(scope="module")
def flight(arena_file: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("open_start")
    return fly_mission(ScenarioOptions(out=out, arena=arena_file, seed=0), limit_s=40.0)


def test_the_preflight_passes_and_the_vehicle_takes_off_and_explores(
        flight: dict[str, Any]) -> None:
    states = [(s["t_s"], s["state"]) for s in flight["states"]]
    names = [s for _, s in states]
    assert names[:4] == ["idle", "preflight", "mission.takeoff", "mission.explore"], names
    assert "stopped" not in names and not flight["crashed"]
    preflight_s = states[2][0] - states[1][0]
    assert preflight_s < load_parameters(MissionParams, "mission").preflight_timeout_s
    assert flight["distance_m"] > 5.0  # flying the exploration's lanes, not hovering
