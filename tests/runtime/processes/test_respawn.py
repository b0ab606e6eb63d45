"""A launch file's ``respawn``: the bookkeeping (delay, the restarts allowed, how a process
ended, in words), the launch file's keys, and a process that dies at once every time
ending the launch after its last restart instead of looping."""

from __future__ import annotations

import io
import signal
from pathlib import Path

import pytest

from runtime.errors import LaunchError
from runtime.launch import LaunchDescription, NodeSpec
from runtime.processes.launcher import process_specs, run_launch
from runtime.processes.respawn import DEFAULT_RESPAWN_MAX, RespawnPolicy, Respawns, exit_text


def test_exit_text_names_the_code_or_the_signal() -> None:
    assert exit_text(1) == "exited with code 1"
    assert exit_text(0) == "exited with code 0"
    assert exit_text(-signal.SIGKILL) == "killed by SIGKILL"
    assert exit_text(-signal.SIGSEGV) == "killed by SIGSEGV"


def test_a_death_is_restarted_after_the_delay_until_the_count_is_used() -> None:
    respawns = Respawns({"navigation": RespawnPolicy(delay_s=2.0, max_count=2)})
    first = respawns.ended("navigation", 1234, -signal.SIGKILL, now=10.0)
    assert first.restart_at == 12.0 and first.count == 1
    assert first.line == ("navigation (pid 1234) died: killed by SIGKILL; restarting in "
                          "2.0 s (1 of 2)")
    second = respawns.ended("navigation", 1240, 1, now=30.0, why="a node_stop fault")
    assert second.restart_at == 32.0 and second.count == 2
    assert "exited with code 1 (a node_stop fault); restarting" in second.line
    third = respawns.ended("navigation", 1250, -signal.SIGKILL, now=40.0)
    assert third.restart_at is None  # the third death ends the launch
    assert third.line.endswith("not restarted: its 2 restarts are used")


def test_a_process_that_finished_or_has_no_policy_is_not_restarted() -> None:
    respawns = Respawns({"pilot": RespawnPolicy(delay_s=0.5)})
    assert respawns.ended("pilot", 7, 0, now=1.0).restart_at is None  # done: exit 0
    assert respawns.used["pilot"] == 0
    lone = respawns.ended("bridge", 8, 1, now=1.0)
    assert lone.restart_at is None and lone.line == "bridge (pid 8) died: exited with code 1"


def test_policy_ranges_are_checked() -> None:
    assert RespawnPolicy().max_count == DEFAULT_RESPAWN_MAX
    with pytest.raises(ValueError, match="respawn_delay"):
        RespawnPolicy(delay_s=-1.0)
    with pytest.raises(ValueError, match="respawn_max"):
        RespawnPolicy(max_count=0)


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "launch.yaml"
    path.write_text(text)
    return path


def test_launch_file_respawn_keys_reach_the_process_spec(tmp_path: Path) -> None:
    description = LaunchDescription.from_yaml(_write(tmp_path, """
nodes:
  - factory: quadmission.examples:Talker
    process: talk
    respawn: true
    respawn_delay: 1.5
  - factory: quadmission.examples:Listener
    process: listen
"""))
    talk, listen = process_specs(description, transport="ros2")
    assert talk.respawn_policy() == RespawnPolicy(1.5, DEFAULT_RESPAWN_MAX)
    assert listen.respawn_policy() is None


@pytest.mark.parametrize(("entry", "problem"), [
    ("respawn: yes please", "respawn: expected true or false"),
    ("respawn_delay: -2", "respawn_delay: expected 0 to 3600"),
    ("respawn_max: 0", "respawn_max: expected a count"),
])
def test_bad_respawn_keys_are_named(tmp_path: Path, entry: str, problem: str) -> None:
    path = _write(tmp_path, f"nodes:\n  - factory: quadmission.examples:Talker\n    {entry}\n")
    with pytest.raises(LaunchError, match=problem):
        LaunchDescription.from_yaml(path)


def test_nodes_of_one_process_must_agree_on_respawn() -> None:
    description = LaunchDescription((
        NodeSpec("quadmission.examples:Talker", process="both", respawn=True),
        NodeSpec("quadmission.examples:Listener", process="both"),
    ))
    with pytest.raises(ValueError, match="process 'both': its nodes disagree on respawn"):
        process_specs(description, transport="ros2")
    lone_delay = LaunchDescription((NodeSpec("quadmission.examples:Talker", respawn_delay=2.0),))
    with pytest.raises(ValueError, match="without respawn: true"):
        process_specs(lone_delay, transport="ros2")


def test_a_process_dying_at_once_every_time_ends_the_launch_after_its_restarts(
        transport_kind: str, domain_id: int) -> None:
    description = LaunchDescription((
        NodeSpec("quadmission.examples:Listener", process="listening"),  # runs on
        NodeSpec("runtime.no_such_module:Node", process="broken", respawn=True,
                 respawn_delay=0.2, respawn_max=2),
    ))
    specs = process_specs(description, transport=transport_kind, domain_id=domain_id,
                          config_dir=None, use_sim_time=False)
    log = io.StringIO()
    result = run_launch(specs, log=log)
    said = log.getvalue()
    assert result.exit_code == 1
    assert result.reason.startswith("process 'broken'"), result.reason
    assert result.reason.endswith("(died; not restarted: its 2 restarts are used)")
    assert "broken (pid " in said and "died: exited with code 1; restarting in 0.2 s (1 of 2)" \
        in said, said
    assert "(2 of 2)" in said and said.count("launch: restarted broken (pid ") == 2
