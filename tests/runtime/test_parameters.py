"""Parameters: YAML defaults, overrides, types, ranges, and errors that name the key."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from runtime import (
    DeterministicExecutor,
    Node,
    Parameter,
    ParameterDescriptor,
    ParameterError,
    param,
)


@dataclass(frozen=True)
class LandParams:
    land_speed: float = param(unit="m/s", range=(0.1, 2.0))
    retries: int = param(range=(0, 10))
    strategy: str = param(choices=("vision", "blind"))
    pads: tuple[int, ...] = param(default=(1, 2), range=(1, 10))


class Lander(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("lander", **kwargs)
        self.params = self.declare_params(LandParams)


def _config(tmp_path: Path, body: str) -> DeterministicExecutor:
    (tmp_path / "lander.yaml").write_text(body)
    return DeterministicExecutor(config_dir=tmp_path)


GOOD = """
lander:
  ros__parameters:
    land_speed: 0.5   # m/s
    retries: 3
    strategy: vision
"""


def test_values_come_from_the_yaml_and_defaults(tmp_path: Path) -> None:
    ex = _config(tmp_path, GOOD)
    node = Lander(context=ex.context)
    ex.add_node(node)
    assert node.params == LandParams(land_speed=0.5, retries=3, strategy="vision", pads=(1, 2))
    assert node.get_parameter("land_speed").value == 0.5


def test_overrides_win_over_the_yaml(tmp_path: Path) -> None:
    ex = _config(tmp_path, GOOD)
    node = Lander(context=ex.context, parameter_overrides={"retries": 7, "pads": [3]})
    assert node.params.retries == 7 and node.params.pads == (3,)


@pytest.mark.parametrize(
    ("yaml_text", "match"),
    [
        (GOOD.replace("0.5", "5.0"), r"lander\.land_speed.*5\.0 m/s is outside the range "
                                     r"\[0\.1, 2\.0\] m/s"),
        (GOOD.replace("retries: 3", "retries: 2.5"), r"lander\.retries.*expected int"),
        (GOOD.replace("vision", "guess"), r"lander\.strategy.*'guess' is not one of"),
        (GOOD.replace("    retries: 3\n", ""), r"lander\.retries: no value"),
        (GOOD + "    pads: [1, 11]\n", r"lander\.pads.*11 is outside"),
        (GOOD.replace("retries: 3", "retries: [3"), r"not valid YAML"),
        ("lander:\n  params:\n    x: 1\n", r"expected a 'ros__parameters' mapping"),
    ],
)
def test_bad_values_name_the_key(tmp_path: Path, yaml_text: str, match: str) -> None:
    ex = _config(tmp_path, yaml_text)
    with pytest.raises(ParameterError, match=match):
        Lander(context=ex.context)


def test_an_unknown_yaml_key_is_an_error_when_the_node_joins(tmp_path: Path) -> None:
    ex = _config(tmp_path, GOOD + "    land_sped: 0.4\n")
    node = Lander(context=ex.context)
    with pytest.raises(ParameterError, match=r"unknown parameter 'land_sped' for node lander"):
        ex.add_node(node)


def test_an_unknown_override_is_an_error(tmp_path: Path) -> None:
    ex = _config(tmp_path, GOOD)
    node = Lander(context=ex.context, parameter_overrides={"retrys": 1})
    with pytest.raises(ParameterError, match="retrys"):
        ex.add_node(node)


def test_set_parameters_validates_like_declaration(tmp_path: Path) -> None:
    ex = _config(tmp_path, GOOD)
    node = Lander(context=ex.context)
    ok, bad_range, bad_name = node.set_parameters([
        Parameter("land_speed", node.get_parameter("land_speed").type, 1.0),
        Parameter("retries", node.get_parameter("retries").type, 99),
        Parameter("nope", node.get_parameter("retries").type, 1),
    ])
    assert ok.successful and node.get_parameter("land_speed").value == 1.0
    assert not bad_range.successful and "outside the range" in bad_range.reason
    assert node.get_parameter("retries").value == 3
    assert not bad_name.successful and "not declared" in bad_name.reason


def test_declare_parameter_rclpy_style(ex: DeterministicExecutor) -> None:
    node = Node("n", context=ex.context)
    rate = node.declare_parameter(
        "rate_hz", 20.0, ParameterDescriptor(unit="Hz", range=(1.0, 100.0))
    )
    assert rate.value == 20.0
    with pytest.raises(ParameterError, match="declared twice"):
        node.declare_parameter("rate_hz", 10.0)
    with pytest.raises(ParameterError, match=r"n\.missing: not declared"):
        node.get_parameter("missing")
