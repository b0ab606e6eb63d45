"""The quadmission command: subcommands listed, real work done, errors said plainly."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from quadmission.cli import COMMANDS, build_parser, main


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
    assert "VEHICLE_CMD_COMPONENT_ARM_DISARM=400" in shown


def test_unknown_type_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["interfaces", "px4_msgs/msg/NoSuchThing"]) == 2
    assert "unknown message type 'px4_msgs/msg/NoSuchThing'" in capsys.readouterr().err


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
