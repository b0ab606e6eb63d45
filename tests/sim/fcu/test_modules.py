"""Module declarations: dataclass validation and loading from dicts and YAML."""

from __future__ import annotations

from pathlib import Path

import pytest

from sim.fcu import (
    EventSpec,
    InitSpec,
    ModuleSpec,
    ModuleSpecError,
    PeriodicSpec,
    TaskGroup,
    load_modules,
    module_from_dict,
    modules_from_yaml,
)
from sim.fcu.modules import AnyOf, FunctionalityRef, ModuleRef, parse_requirement

YAML = """
modules:
  - name: imu_mpu
    group: sensors
    provides: [imu]
    inits: [imu_mpu_init]
    periodics:
      - {fun: imu_mpu_periodic, freq_hz: 500}
    events: [imu_mpu_event]
  - name: ins_ekf
    group: estimation
    depends: "imu_mpu,gps_ublox|gps_sim,@baro"   # the seed's Figure 3 syntax
    conflicts: [ins_complementary, "@ins_alt"]
    provides: [ins]
    periodics:
      - {fun: ins_ekf_predict, freq_hz: 250, cost: 4}
      - {fun: ins_ekf_gps, period_s: 0.1, delay: 0.5, autorun: false}
"""


def test_yaml_loads_every_field() -> None:
    imu, ins = modules_from_yaml(YAML)
    assert imu == ModuleSpec(
        "imu_mpu",
        TaskGroup.SENSORS,
        provides=("imu",),
        inits=(InitSpec("imu_mpu_init"),),
        periodics=(PeriodicSpec("imu_mpu_periodic", freq_hz=500),),
        events=(EventSpec("imu_mpu_event"),),
    )
    assert ins.depends == ("imu_mpu", "gps_ublox|gps_sim", "@baro")
    assert ins.requirements() == (
        ModuleRef("imu_mpu"),
        AnyOf((ModuleRef("gps_ublox"), ModuleRef("gps_sim"))),
        FunctionalityRef("baro"),
    )
    assert ins.conflict_refs() == (ModuleRef("ins_complementary"), FunctionalityRef("ins_alt"))
    gps = ins.periodics[1]
    assert (gps.period_s, gps.delay, gps.autorun, gps.rate_hz) == (0.1, 0.5, False, 10.0)
    assert ins.periodics[0].cost == 4


def test_load_modules_reads_a_file(tmp_path: Path) -> None:
    path = tmp_path / "modules.yaml"
    path.write_text(YAML, encoding="utf-8")
    assert load_modules(path) == modules_from_yaml(YAML)


def test_provides_accepts_the_at_prefix() -> None:
    assert ModuleSpec("imu", provides=("@imu",)).functionalities() == ("imu",)


@pytest.mark.parametrize(
    ("data", "key", "words"),
    [
        ({"name": "m", "grup": "sensors"}, "modules[0].grup", "unknown key"),
        ({"group": "sensors"}, "modules[0].name", "missing"),
        ({"name": "m", "group": "sensor"}, "modules[0].group", "not a task group"),
        ({"name": "m", "depends": ["@"]}, "modules[0].depends[0]", "not a valid"),
        ({"name": "m", "depends": ["a|"]}, "modules[0].depends[0]", "not a valid"),
        ({"name": "m", "depends": 3}, "modules[0].depends", "list of names"),
        ({"name": "m", "conflicts": ["a|b"]}, "modules[0].conflicts[0]", "only allowed"),
        ({"name": "m", "periodics": {"fun": "f"}}, "modules[0].periodics", "expected a list"),
        (
            {"name": "m", "periodics": [{"fun": "f", "freq_hz": 10, "delay": 1.0}]},
            "modules[0].periodics[0].delay",
            "outside [0, 1)",
        ),
        (
            {"name": "m", "periodics": [{"fun": "f", "freq_hz": 10, "period_s": 0.1}]},
            "modules[0].periodics[0].freq_hz",
            "exactly one",
        ),
        (
            {"name": "m", "periodics": [{"fun": "f"}]},
            "modules[0].periodics[0].freq_hz",
            "exactly one",
        ),
        (
            {"name": "m", "periodics": [{"fun": "f", "freq_hz": -5}]},
            "modules[0].periodics[0].freq_hz",
            "must be > 0",
        ),
        (
            {"name": "m", "periodics": [{"fun": "f", "freq_hz": 5, "hz": 5}]},
            "modules[0].periodics[0].hz",
            "unknown key",
        ),
        (
            {"name": "m", "periodics": [{"fun": "f", "freq_hz": 5, "cost": -1}]},
            "modules[0].periodics[0].cost",
            ">= 0",
        ),
        (
            {"name": "m", "events": ["e", "e"]},
            "modules[0].events[1]",
            "duplicate function",
        ),
    ],
)
def test_bad_declarations_name_the_key(data: dict[str, object], key: str, words: str) -> None:
    with pytest.raises(ModuleSpecError) as info:
        module_from_dict(data, "modules[0]")
    assert info.value.key == key, str(info.value)
    assert words in str(info.value)


def test_yaml_top_level_is_checked() -> None:
    with pytest.raises(ModuleSpecError, match="top-level"):
        modules_from_yaml("- name: m\n")
    with pytest.raises(ModuleSpecError) as info:
        modules_from_yaml("modules: []\nmain_freq_hz: 500\n")
    assert info.value.key == "main_freq_hz"


def test_delay_bounds() -> None:
    assert PeriodicSpec("f", freq_hz=10, delay=0.0).delay == 0.0
    assert PeriodicSpec("f", freq_hz=10, delay=0.999).delay == 0.999
    for bad in (-0.1, 1.0, True):
        with pytest.raises(ModuleSpecError, match="delay"):
            PeriodicSpec("f", freq_hz=10, delay=bad)


def test_parse_requirement_forms() -> None:
    assert parse_requirement("imu") == ModuleRef("imu")
    assert parse_requirement("@imu") == FunctionalityRef("imu")
    assert parse_requirement("a|@b") == AnyOf((ModuleRef("a"), FunctionalityRef("b")))
    assert str(parse_requirement("a|@b")) == "a|@b"


def test_task_group_order_is_fixed() -> None:
    order = [g.value for g in TaskGroup]
    assert order == [
        "mcu",
        "core",
        "sensors",
        "estimation",
        "radio_control",
        "control",
        "actuators",
        "datalink",
        "telemetry",
        "default",
    ]
    assert [g.rank for g in TaskGroup] == list(range(len(order)))
