"""The quadmission command: subcommands listed, real work done, errors said plainly."""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import interfaces
from interfaces.errors import UnknownTypeError
from quadmission.cli import (
    COMMANDS,
    EXIT_BAD_INPUT,
    EXIT_CODES,
    Command,
    build_parser,
    main,
    project_errors,
)
from quadmission.errors import ExperimentError
from runtime import LaunchDescription
from runtime.errors import LaunchError, ParameterError
from runtime.parameters import config_path
from sim.errors import ArenaError
from sim.fcu.errors import DependencyCycleError

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE_LAUNCH = config_path("launch/example.yaml")


def _run_cli(*args: str, stdout: int | None = subprocess.PIPE) -> subprocess.CompletedProcess[str]:
    """``python -m quadmission.cli ARGS`` on this checkout, as a user would run it."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": "egl"}
    return subprocess.run([sys.executable, "-m", "quadmission.cli", *args], env=env,
                          stdout=stdout, stderr=subprocess.PIPE, text=True, timeout=300,
                          check=False)


def test_help_lists_every_subcommand(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    for command in COMMANDS:
        assert command.name in out


def test_interfaces_lists_and_shows_types(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["interfaces", "--package", "px4_msgs"]) == 0
    listed = capsys.readouterr().out.split()
    assert "px4_msgs/msg/VehicleOdometry" in listed
    assert all(name.startswith("px4_msgs/") for name in listed)
    assert main(["interfaces", "px4_msgs/msg/VehicleCommand"]) == 0
    shown = capsys.readouterr().out
    assert "uint16 VEHICLE_CMD_COMPONENT_ARM_DISARM=400" in shown


def test_interfaces_graph_lists_each_name_with_its_kind_type_qos_and_ends(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["interfaces", "--graph"]) == 0
    out = capsys.readouterr().out
    block = out[out.index("/fcu/odometry  [topic]"):].split("\n/", 1)[0]
    assert block.splitlines() == [
        "/fcu/odometry  [topic]  nav_msgs/msg/Odometry",
        "  qos: best effort, volatile, keep last 5",
        "  publishers: fcu_bridge",
        "  subscribers: flight_control, aruco_scanner, precision_land, navigator, mission, "
        "navigate_pilot, square_pilot, ground_station (monitor)"]
    assert "/navigation/navigate  [action]  quadmission_interfaces/action/Navigate" in out
    assert "/fcu/pose_at  [service]  quadmission_interfaces/srv/PoseAt" in out
    assert main(["interfaces", "--graph", "px4_msgs/msg/VehicleOdometry"]) == 2
    assert "--graph lists the whole graph" in capsys.readouterr().err


def test_interfaces_shows_each_fields_type_name_and_default(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["interfaces", "px4_msgs/msg/VehicleOdometry"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(re.fullmatch(r"uint64\s+timestamp\s+0", line) for line in lines), lines
    assert any(re.fullmatch(r"float32\[3\]\s+position\s+\[0\.0, 0\.0, 0\.0\]", line)
               for line in lines), lines
    assert main(["interfaces", "nav_msgs/msg/Path"]) == 0
    assert capsys.readouterr().out.split() == [
        "std_msgs/msg/Header", "header", "geometry_msgs/msg/PoseStamped[]", "poses"]


def test_interfaces_shows_an_actions_goal_result_and_feedback(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["interfaces", "quadmission_interfaces/action/Reach"]) == 0
    sections = capsys.readouterr().out.split("---\n")
    action = interfaces.get_action("quadmission_interfaces/action/Reach")
    parts = (("goal", action.Goal), ("result", action.Result), ("feedback", action.Feedback))
    assert len(sections) == len(parts), sections
    for text, (part, cls) in zip(sections, parts, strict=True):
        lines = text.splitlines()
        assert lines[0] == f"# {part}: {interfaces.type_name(cls)}"
        constants, fields = interfaces.describe(cls)
        shown = [line.split()[1] for line in lines[1:] if line and "=" not in line]
        assert shown == [f.name for f in fields], (part, lines)
        assert [line.split()[1] for line in lines if "=" in line] == [
            f"{c.name}={c.value}" for c in constants]
    assert main(["interfaces", "quadmission_interfaces/PlanPath"]) == 0  # a service
    shown = capsys.readouterr().out
    assert shown.startswith("# request: quadmission_interfaces/srv/PlanPath_Request\n")
    assert "---\n# response: quadmission_interfaces/srv/PlanPath_Response\n" in shown


def test_unknown_type_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["interfaces", "px4_msgs/msg/NoSuchThing"]) == 2
    assert "unknown message type 'px4_msgs/msg/NoSuchThing'" in capsys.readouterr().err
    assert main(["interfaces", "quadmission_interfaces/action/NoSuchThing"]) == 2
    assert ("unknown action type 'quadmission_interfaces/action/NoSuchThing'"
            in capsys.readouterr().err)


def test_launch_runs_nodes_in_simulated_time(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    launch_file = tmp_path / "l.yaml"
    launch_file.write_text(
        "nodes:\n  - factory: tests.runtime.test_names_and_launch:Echo\n    name: e\n"
    )
    assert main(["launch", str(launch_file), "--duration", "2", "--config-dir",
                 str(tmp_path)]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["sim_time_s"] == pytest.approx(2.0)


def test_launch_of_a_missing_file_says_so(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["launch", "/nonexistent/launch.yaml"]) == 2
    assert "/nonexistent/launch.yaml" in capsys.readouterr().err


def test_parser_requires_a_subcommand() -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args([])


def test_fcu_schedule_prints_the_schedule_and_measured_rates(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["fcu-schedule", "--flight-s", "1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    functions = {p["function"]: p for p in report["periodics"]}
    assert functions["ekf_update"]["freq_hz"] == 500 and functions["ekf_update"]["prescaler"] == 1
    assert functions["pub_battery_status"]["prescaler"] == 500
    assert report["module_order"][0] == "imu_driver"
    assert main(["fcu-schedule", "--flight-s", "1", "--offsets", "naive"]) == 0
    text = capsys.readouterr().out
    assert "offsets naive" in text and "mc_rate_control" in text and "duty avg us" in text


def test_help_documents_the_exit_codes(capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["--help"], ["launch", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        out = capsys.readouterr().out
        assert "exit codes:" in out
        for code in ("0", "1", "2", "130", "141"):
            assert re.search(rf"^  {code} ", out, re.M), (argv, code)
    assert "exit codes:" in EXIT_CODES


def test_a_duration_must_be_positive(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["launch", str(EXAMPLE_LAUNCH), "--duration", "-1"])
    assert exit_info.value.code == 2
    assert "-1 must be a positive number of seconds" in capsys.readouterr().err


# -- errors: the project's own are bad input (2, one line), anything else is a bug ----------


def _raising(exc: BaseException) -> Command:
    def run(args: argparse.Namespace) -> int:
        raise exc

    return Command("boom", "raise an exception", lambda p: None, run)


@pytest.mark.parametrize("exc", [
    UnknownTypeError("unknown message type 'x/msg/Y'"),
    ParameterError("5.0 is outside the allowed range [0.1, 2] m/s", key="talker.rate_hz",
                   source="config/talker.yaml"),
    LaunchError("l.yaml: nodes[0]: missing 'factory'"),
    ArenaError("pads[3].center", "outside the field", "a.yaml"),
    DependencyCycleError(["a", "b", "a"]),
    ExperimentError("estimator(s) ['px4'] never converged in 1 s: run longer"),
], ids=lambda e: type(e).__name__)
def test_the_projects_own_errors_are_one_line_and_exit_2(
    exc: Exception, capsys: pytest.CaptureFixture[str]
) -> None:
    assert isinstance(exc, project_errors())
    assert main(["boom"], commands=(_raising(exc),)) == 2
    err = capsys.readouterr().err
    assert err == f"quadmission boom: error: {exc}\n"


@pytest.mark.parametrize("exc", [ZeroDivisionError("division by zero"), KeyError("k"),
                                 ValueError("a bug, not bad input")])
def test_any_other_exception_is_a_bug_and_keeps_its_traceback(exc: Exception) -> None:
    with pytest.raises(type(exc)):
        main(["boom"], commands=(_raising(exc),))


def test_a_bug_shows_its_traceback_and_exits_1() -> None:
    script = ("import sys; from quadmission.cli import Command, main\n"
              "def run(args): return 1 // 0\n"
              "sys.exit(main(['boom'], commands=(Command('boom', '', lambda p: None, run),)))\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                          text=True, timeout=120, check=False)
    assert done.returncode == 1
    assert "Traceback (most recent call last)" in done.stderr
    assert "ZeroDivisionError" in done.stderr


def test_a_closed_output_pipe_is_quiet() -> None:
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader is gone before anything is written (as after head -1)
    try:
        done = _run_cli("interfaces", stdout=write_end)
    finally:
        os.close(write_end)
    assert done.stderr == ""
    assert done.returncode == 141


def test_a_yaml_syntax_error_in_a_parameter_file_is_one_line_naming_it(tmp_path: Path) -> None:
    bad = tmp_path / "talker.yaml"
    bad.write_text("talker:\n  ros__parameters:\n    rate_hz: [10\n", encoding="utf-8")
    done = _run_cli("launch", str(EXAMPLE_LAUNCH), "--duration", "1",
                    "--config-dir", str(tmp_path))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith(f"quadmission launch: error: {bad}: invalid YAML at line 4")


def test_a_yaml_syntax_error_in_an_arena_file_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "arena.yaml"
    bad.write_text("name: x\npads: [1, 2\n", encoding="utf-8")
    assert main(["sim", "--arena", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[-1].startswith(f"quadmission sim: error: {bad}: invalid YAML at line 3")


# -- the example launch file ------------------------------------------------------------------


def test_quadmission_launch_runs_the_example() -> None:
    done = _run_cli("launch", str(EXAMPLE_LAUNCH), "--duration", "2")
    assert done.returncode == 0, done.stderr
    rate_hz = LaunchDescription.from_yaml(EXAMPLE_LAUNCH).nodes[0].parameters["rate_hz"]
    heard = re.findall(r"\[listener\] heard 'hello (\d+)'", done.stderr)
    assert heard == [str(n) for n in range(1, round(2.0 * rate_hz) + 1)]
    assert json.loads(done.stdout)["sim_time_s"] == pytest.approx(2.0)


@pytest.mark.parametrize(("extra", "named"), [
    (["--gcs"], "--gcs: not available with a launch file with a simulator"),
    (["--rtf", "2"], "--rtf: not available with a launch file with a simulator"),
    (["--transport", "ros2", "--domain-id", "300"], "--domain-id 300 is outside 0..232"),
])
def test_launch_refuses_services_it_would_ignore(
        extra: list[str], named: str, capsys: pytest.CaptureFixture[str]) -> None:
    square = config_path("launch/square.yaml")
    assert main(["launch", str(square), *extra]) == EXIT_BAD_INPUT
    assert named in capsys.readouterr().err


@pytest.mark.parametrize(("transport", "said"), [
    ("dds", "the Cyclone DDS transport 'dds' was retired; use --transport ros2"),
    ("zenoh", "'zenoh' is not a transport: inproc or ros2"),
])
def test_launch_names_a_transport_it_does_not_have(
        transport: str, said: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["launch", str(config_path("launch/square.yaml")), "--transport", transport])
    assert exited.value.code == EXIT_BAD_INPUT
    assert said in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "said"), [
    (["sim", "--scenario", "navigate", "--fault", "pad_occluded@0,pad=3"],
     "the navigate scenario cannot take pad_occluded (it lands on no pad)"),
    (["launch", "config/launch/mission.yaml", "--transport", "ros2", "--fault",
      "operator_abort@3"], "operator_abort@3: not in a launch over ros2"),
    (["launch", "config/launch/mission.yaml", "--transport", "ros2", "--fault",
      "node_stop@3,name=nope"], "a process of the launch file (companion, mission, "),
    (["launch", "config/launch/mission.yaml", "--transport", "ros2", "--fault",
      "node_stop@3:5,name=navigator"], "comes back by its launch file's respawn"),
])
def test_a_fault_the_run_cannot_take_is_refused_naming_it(
        argv: list[str], said: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    assert said in capsys.readouterr().err
