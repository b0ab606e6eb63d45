"""The wide pad search beside an obstacle, flown through the whole stack (issue 39, item 4).

A pad with a 1.5 m box standing inside the mission's wide search radius beside it, its
marker covered (``pad_occluded``), so the first approach misses it and the precision
landing searches its whole spiral, with the mapping node and the path finder flying as in
a mission. Judged from the simulator's truth, here in the app layer: the vehicle never
comes within the navigator's clearance of the box (the path finder's footprint + margin
beside it, its vertical clearance above it) and does not collide. Slow: one flight."""

from __future__ import annotations

import numpy as np
import pytest

from fsm.params import MissionParams
from navigation.params import PathFinderParams
from navigation.precision_land_node import PRECISION_LAND
from quadmission.scenarios.precision_landing.scenario import fly_episode, start_position
from runtime.parameters import load_parameters
from sim.arena import load_arena
from sim.fault_spec import parse_fault

pytestmark = pytest.mark.slow

FINDER = load_parameters(PathFinderParams, "path_finder")
CLEARANCE = FINDER.footprint_radius + FINDER.safety_margin  # m, beside an obstacle
ABOVE = FINDER.vertical_clearance  # m, over it
#: m, what the flight may give away against the planner's rule: the map's voxels hold each
#: surface point at its 0.1 m voxel's centre (0.05 m) and a reach stops within 0.03 m
TOLERANCE = 0.05 + 0.03
BOX_CENTER, BOX_SIZE = (4.3, 4.0), (0.6, 0.6, 1.5)  # 1.5 m tall: the search altitude

#: long enough to fly the wide spiral's three rings round the box (25 points)
WHOLE_SPIRAL = {"search_timeout_s": 100.0}

ARENA = f"""
name: wide-search
lighting: light
field: {{size: [8.0, 8.0, 4.0], wall_thickness: 0.2}}
start_pad: 1
obstacles:
  - {{center: [{BOX_CENTER[0]}, {BOX_CENTER[1]}],
     size: [{BOX_SIZE[0]}, {BOX_SIZE[1]}, {BOX_SIZE[2]}]}}
pads:
  - {{id: 1, center: [3.0, 4.0]}}
"""


def depth_in_clearance(positions: np.ndarray) -> np.ndarray:
    """How deep [m] each position is inside the box grown by the clearance (CLEARANCE in
    x and y, ABOVE over its top): 0 outside."""
    lo = np.array([BOX_CENTER[0] - BOX_SIZE[0] / 2 - CLEARANCE,
                   BOX_CENTER[1] - BOX_SIZE[1] / 2 - CLEARANCE, -np.inf])
    hi = np.array([BOX_CENTER[0] + BOX_SIZE[0] / 2 + CLEARANCE,
                   BOX_CENTER[1] + BOX_SIZE[1] / 2 + CLEARANCE, BOX_SIZE[2] + ABOVE])
    return np.maximum(np.min(np.minimum(positions - lo, hi - positions), axis=1), 0.0)


def test_the_clearance_measure():
    x_face = BOX_CENTER[0] - BOX_SIZE[0] / 2
    p = np.array([[x_face - CLEARANCE - 0.01, BOX_CENTER[1], 1.0],  # just outside beside
                  [x_face - CLEARANCE + 0.1, BOX_CENTER[1], 1.0],  # 0.1 m inside beside
                  [BOX_CENTER[0], BOX_CENTER[1], BOX_SIZE[2] + ABOVE + 0.01]])  # over it
    assert depth_in_clearance(p) == pytest.approx([0.0, 0.1, 0.0])


@pytest.fixture(scope="module")
def episode(tmp_path_factory: pytest.TempPathFactory):
    path = tmp_path_factory.mktemp("wide") / "arena.yaml"
    path.write_text(ARENA)
    arena = load_arena(path)
    pad = arena.pad(1)
    start = start_position(arena, pad, np.random.default_rng(0))
    wide = load_parameters(MissionParams, "mission").search_radius_wide
    return fly_episode(arena, pad, start, seed=0, mapped=True, search_radius=wide,
                       faults=[parse_fault("pad_occluded@0,pad=1")],
                       landing_overrides=WHOLE_SPIRAL)


def test_the_wide_search_keeps_the_navigators_clearance_from_the_box(episode):
    assert episode.crash is None, episode.message
    assert episode.result_code == PRECISION_LAND.Result.RESULT_MARKER_NOT_FOUND, \
        episode.message  # the whole search was flown: the marker was covered
    truth = episode.trajectory
    depth = depth_in_clearance(truth.position)
    worst = int(np.argmax(depth))
    assert depth[worst] <= TOLERANCE, (
        f"at {truth.t[worst]:.1f} s the vehicle was at {truth.position[worst].round(2)}, "
        f"{depth[worst]:.2f} m inside the {CLEARANCE} m clearance of the box")


def test_the_search_went_round_the_box_not_only_away_from_it(episode):
    # the spiral's points beyond the box (x > its far face plus the clearance) were flown to:
    # the outer ring's, 0.8 m past it
    far_face = BOX_CENTER[0] + BOX_SIZE[0] / 2
    airborne = episode.trajectory.position[episode.trajectory.position[:, 2] > 1.0]
    assert airborne[:, 0].max() > far_face + CLEARANCE
