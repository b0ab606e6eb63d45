"""The companion in real time: ``config/launch/companion.yaml`` (its node list as written)
flies ``quadmission vehicle`` on the wall clock, each in processes of its own, with the
simulated operator beside them (:func:`quadmission.scenarios.mission.realtime.fly_realtime`),
scored against the vehicle's ground truth.

The arena is small, so that a flight through the take-off, the robot, one pad's precision
landing and the take-off after it is about a minute and a half of flight at real time
(the whole mission on it: 93 s simulated, in process). A companion that stops streaming
setpoints in flight leaves the vehicle's FCU to its failsafe. No wall-clock figure is
asserted: on a busy host the vehicle falls behind and says so, the mission may HOLD and
RESUME, and the outcome must still hold.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from quadmission.scenarios.mission.realtime import (
    COMPANION_YAML,
    RealtimeOptions,
    _settle,
    fly_realtime,
)
from quadmission.vehicle.run import VehicleOptions
from quadmission.vehicle.truth import TOUCHDOWN_SAID, load_truth
from sim.arena import PAD_SIZE
from tests.runtime.processes.conftest import needs_ros2, ros_domain

pytestmark = [needs_ros2, pytest.mark.slow]

# 7 x 5 m, two pads; the target robot parked beside the explore's first lane, so the
# exploration finds it within seconds
ARENA = """\
name: small
lighting: light
field:
  size: [7.0, 5.0, 3.5]
  wall_thickness: 0.2
start_pad: 1
obstacles: []
pads:
  - {id: 1, center: [1.5, 2.5]}
  - {id: 2, center: [4.5, 2.5]}
robots:
  - marker_id: 19
    speed: 0.05
    loop: false
    path: [[1.5, 1.0], [1.7, 1.0]]
    points: {1: 10, 2: 30}
"""
COMPANION_NICE = -3  # above the other tests, below the vehicle's -5 (the hardware's)
_TIMEOUT_S = 900.0  # host seconds the companion may take at most: a generous bound
_DESCENT_S = 90.0  # host seconds the vehicle may take to come down after the companion
_ON_FLOOR_Z_M = 0.25  # the body's centre on the floor (0.15 m) or a pad


def _fly(tmp_path: Path, until_state: str, settle_s: float = 3.0,
         settle_until: str | None = None) -> dict[str, Any]:
    arena = tmp_path / "small.yaml"
    arena.write_text(ARENA)
    vehicle = VehicleOptions(out=tmp_path / "unused", arena=arena,
                             domain_id=ros_domain("vehicle"))
    # the companion before the other tests beside it (as a flight stack before other work
    # on its computer): starved by a parallel worker, its flight loop went silent for 0.5 s
    # after arming once in four runs on a loaded host ("takeoff: FCU not connected")
    return fly_realtime(RealtimeOptions(out=tmp_path / "run", vehicle=vehicle,
                                        until_state=until_state, timeout_s=_TIMEOUT_S,
                                        settle_s=settle_s, settle_until=settle_until,
                                        companion_nice=COMPANION_NICE))


@pytest.mark.realtime  # alone, after the parallel suite: beside a parallel worker it failed
def test_companion_yaml_flies_the_vehicle_through_a_takeoff_a_pad_and_its_landing(
        tmp_path: Path) -> None:
    report = _fly(tmp_path, "mission.pad.takeoff")  # entered once the first pad is landed
    run = tmp_path / "run"
    assert report["companion_exit_code"] == 0, (run / "companion.log").read_text()[-4000:]
    assert report["final_state"] == "mission.pad.takeoff", report["verdict"]
    states = [s["state"] for s in report["states"]]
    for state in ("preflight", "mission.takeoff", "mission.explore", "mission.pad.land"):
        assert state in states, states
    (landed,) = report["landings"]
    assert landed["inside_pad"] and landed["touchdown_error_m"] < PAD_SIZE / 4, landed
    assert not report["crashed"]
    # the vehicle's truth saw the touchdown too, at the mission's landing
    assert any(abs(t["t_s"] - landed["t_s"]) < 5.0 for t in report["touchdowns"]), report
    behind = report["vehicle"]["behind"]  # reported, whatever the host's load made it
    assert {"episodes", "max_lag_s", "behind_s"} <= set(behind)
    # the offboard stream as the FCU took it, in OFFBOARD: seconds of it at >= 2 Hz
    assert report["vehicle"]["setpoints"]["heartbeats"] > 20
    # the visual odometry the FCU fused (30 Hz over the flight), each sample's age on its
    # clock: positive, whatever the load
    vision = report["vehicle"]["vision"]
    assert vision["fused"] > 300 and 0.0 < vision["age_p50_ms"] <= vision["age_max_ms"]
    # every companion node timed its callbacks, in the process companion.yaml puts it in
    timed = report["callbacks"]
    assert {node: c["process"] for node, c in timed.items() if c["process"] != "operator"} == {
        "fcu_bridge": "companion", "vio": "companion", "flight_control": "companion",
        "aruco_scanner": "perception", "precision_land": "perception",
        "mapping": "navigation", "path_finder": "navigation", "navigator": "navigation",
        "mission": "mission"}
    assert all(timed[node]["run"]["n"] > 0 for node in timed)
    # companion.yaml's nodes, as written: the run only told them the arena
    ours = yaml.safe_load((run / "companion.yaml").read_text())["nodes"]
    theirs = yaml.safe_load(COMPANION_YAML.read_text())["nodes"]
    assert [(n["factory"], n["process"]) for n in ours] == \
        [(n["factory"], n["process"]) for n in theirs]


def test_a_companion_that_stops_streaming_setpoints_leaves_the_fcu_to_its_failsafe(
        tmp_path: Path) -> None:
    """The companion ends as the exploration starts, the vehicle in the air: PX4's
    COM_OF_LOSS_T later the FCU fails safe (offboard lost) and holds. The visual odometry
    went with the companion, so its position-loss failsafe follows: DESCEND, level, to
    the floor, where the vehicle stays (by the vehicle's truth: without a barometer the
    FCU's land detector may take its 8 s minimal-thrust rule, or not see it at all)."""
    # until the vehicle says its touchdown, or a bound of host time: on a busy host the
    # vehicle falls behind the wall clock (25 s of host time once ended before the descent)
    report = _fly(tmp_path, "mission.explore", settle_s=_DESCENT_S, settle_until=TOUCHDOWN_SAID)
    assert report["companion_exit_code"] == 0, report["verdict"]
    stopped_s = report["states"][-1]["t_s"]  # the companion's last word
    late = [f for f in report["fcu_failsafes"] if f["t_s"] > stopped_s]
    assert late and late[0]["reason"] == "OFFBOARD_LOSS", report["fcu_failsafes"]
    assert not report["crashed"], report["verdict"]
    truth = load_truth(tmp_path / "run" / "vehicle").trajectory
    after = truth.t > late[0]["t_s"]
    z, speed = truth.position[after, 2], np.linalg.norm(truth.velocity[after], axis=1)
    assert z[0] > 1.0, f"in the air at the failsafe: z = {z[0]:.2f} m"
    assert z[-1] < _ON_FLOOR_Z_M and speed[-1] < 0.05, (z[-1], speed[-1])


def test_the_settle_ends_on_the_vehicles_word_said_after_the_companion_stopped(
        tmp_path: Path) -> None:
    """``settle_until``: the vehicle's log says the phrase after the byte it had reached
    when the companion stopped; a phrase said before does not count, and without it the
    settle lasts until the vehicle ends (or ``settle_s``)."""
    log = tmp_path / "vehicle.log"
    log.write_text(f"[vehicle] {TOUCHDOWN_SAID} 3.00 s at (1.0, 1.0) m\n")  # before the stop
    said = log.stat().st_size
    options = RealtimeOptions(out=tmp_path, vehicle=VehicleOptions(out=tmp_path),
                              settle_s=_TIMEOUT_S, settle_until=TOUCHDOWN_SAID)
    script = ("import sys, time; time.sleep(float(sys.argv[1])); "
              "print(sys.argv[2], flush=True); time.sleep(float(sys.argv[3]))")
    with log.open("a") as out:  # says something else, then ends: the settle ends with it
        other = subprocess.Popen([sys.executable, "-c", script, "0.5", "nav_state", "1"],
                                 stdout=out)
        _settle(other, log, said, options)
        assert other.poll() is not None  # it waited for the end, not for the old word
        # says the phrase, then lives on: the settle ends on the phrase
        speaker = subprocess.Popen([sys.executable, "-c", script, "0.5",
                                    f"[vehicle] {TOUCHDOWN_SAID} 9.00 s", "600"], stdout=out)
        try:
            _settle(speaker, log, log.stat().st_size, options)
            assert speaker.poll() is None  # ended by its word, the vehicle still running
        finally:
            speaker.kill()
            speaker.wait()
