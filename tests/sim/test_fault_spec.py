"""Fault specs: the string and YAML forms parse to the same faults; bad input is refused
with the bad part named."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from sim.fault_spec import Fault, FaultKind, FaultSpecError, load_faults, parse_fault


def test_a_spec_gives_kind_time_duration_and_keys_with_defaults() -> None:
    f = parse_fault("wind_gust@35.5:2,force=3")
    assert (f.kind, f.at_s, f.duration_s, f.end_s) == (FaultKind.WIND_GUST, 35.5, 2.0, 37.5)
    assert f.value("force") == 3.0 and f.value("direction_deg") == 0.0  # the default
    assert parse_fault(f.spec()) == f  # the spec string replays it


def test_without_a_duration_an_outage_lasts_to_the_end() -> None:
    f = parse_fault("vio_stop@40")
    assert f.duration_s is None and f.end_s == math.inf


def test_the_yaml_file_gives_the_same_faults(tmp_path: Path) -> None:
    path = tmp_path / "faults.yaml"
    path.write_text("- {kind: vio_stop, at_s: 40, duration_s: 5}\n"
                    "- {kind: wind_gust, at_s: 35, duration_s: 2, force: 3, direction_deg: 90}\n"
                    "- {kind: battery_critical, at_s: 30}\n")
    assert load_faults(path) == (parse_fault("vio_stop@40:5"),
                                 parse_fault("wind_gust@35:2,force=3,direction_deg=90"),
                                 parse_fault("battery_critical@30"))


@pytest.mark.parametrize(("spec", "message"), [
    ("vio_stp@3", "unknown fault kind 'vio_stp' (known: vio_stop, link_lost"),
    ("vio_stop@-3", "fault 'vio_stop@-3': time must be >= 0"),
    ("vio_stop@x", "time 'x' is not a number"),
    ("vio_stop@3:0", "duration must be > 0"),
    ("vio_stop", "expected KIND@T"),
    ("wind_gust@3", "wind_gust needs a duration"),
    ("battery_low@3:4", "battery_low takes no duration"),
    ("wind_gust@3:1,speed=2", "unknown key 'speed' for wind_gust (known: direction_deg, force)"),
    ("wind_gust@3:1,force=500", "force=500 is outside [0, 50] N"),
    ("battery_low@3,remaining=2", "remaining=2 is outside [0, 1]"),
    ("wind_gust@3:1,force", "'force' is not key=value"),
])
def test_bad_specs_name_the_bad_part(spec: str, message: str) -> None:
    with pytest.raises(FaultSpecError) as info:
        parse_fault(spec)
    assert message in str(info.value)


def test_a_bad_yaml_entry_names_the_file_and_the_entry(tmp_path: Path) -> None:
    path = tmp_path / "faults.yaml"
    path.write_text("- {kind: vio_stop, at_s: 4}\n- {kind: link_lost}\n")
    with pytest.raises(FaultSpecError, match=r"faults.yaml: fault 2: missing 'at_s'"):
        load_faults(path)
    path.write_text("kind: vio_stop\n")
    with pytest.raises(FaultSpecError, match="expected a list of faults"):
        load_faults(path)


def test_faults_made_in_code_are_checked_too() -> None:
    with pytest.raises(FaultSpecError, match="unknown key 'force' for vio_stop"):
        Fault.of(FaultKind.VIO_STOP, 1.0, force=2.0)
