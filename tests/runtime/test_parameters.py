"""Parameters: YAML defaults, overrides, types, ranges, and errors that name the key."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import pytest

import runtime
from runtime import (
    DeterministicExecutor,
    Node,
    Parameter,
    ParameterDescriptor,
    ParameterError,
    param,
)
from runtime.parameters import (
    CONFIG_DIR_ENV,
    config_dir,
    config_path,
    load_parameters,
    parameter_fields,
    parameters_from_yaml,
    validate_parameters,
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
        (GOOD.replace("0.5", "5.0"), r"lander\.yaml: lander\.land_speed: 5\.0 is outside the "
                                     r"allowed range \[0\.1, 2\] m/s$"),
        (GOOD.replace("retries: 3", "retries: 2.5"),
         r"lander\.yaml: lander\.retries: 2\.5 must be an integer in the allowed range \[0, 10\]$"),
        (GOOD.replace("vision", "guess"),
         r"lander\.yaml: lander\.strategy: 'guess' is not one of vision, blind$"),
        (GOOD.replace("    retries: 3\n", ""), r"^lander\.retries: no value"),
        (GOOD + "    pads: [1, 11]\n", r"lander\.yaml: lander\.pads\[1\]: 11 is outside"),
        (GOOD.replace("retries: 3", "retries: [3"),
         r"lander\.yaml: invalid YAML at line 6, column \d+: .*$"),
        ("lander:\n  params:\n    x: 1\n",
         r"lander\.yaml: lander: expected a single 'ros__parameters' mapping, found keys: params"),
    ],
)
def test_bad_values_name_the_file_the_key_and_what_is_allowed(
    tmp_path: Path, yaml_text: str, match: str
) -> None:
    ex = _config(tmp_path, yaml_text)
    with pytest.raises(ParameterError, match=match) as caught:
        Lander(context=ex.context)
    assert "\n" not in str(caught.value)


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
    assert not bad_range.successful and "outside the allowed range" in bad_range.reason
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



def test_post_set_callbacks_hear_each_change_made_and_none_refused(
        ex: DeterministicExecutor) -> None:
    """rclpy's add_post_set_parameters_callback: after the value is the node's, once per
    parameter; a change refused (by its range or an on-set callback) is not heard."""
    from runtime.parameters import SetParametersResult

    node = Node("n", context=ex.context)
    gain = node.declare_parameter("gain", 0.5, ParameterDescriptor(range=(0.0, 1.0)))
    node.declare_parameter("locked", 1)
    node.add_on_set_parameters_callback(
        lambda ps: SetParametersResult(ps[0].name != "locked", "locked"))
    heard: list[tuple[str, object, object]] = []
    node.add_post_set_parameters_callback(lambda ps: heard.extend(
        (p.name, p.value, node.get_parameter(p.name).value) for p in ps))
    results = node.set_parameters([Parameter("gain", gain.type, 0.25),
                                   Parameter("gain", gain.type, 2.0),
                                   Parameter("locked", gain.type, 2),
                                   Parameter("gain", gain.type, 1)])
    assert [r.successful for r in results] == [True, False, False, True]
    assert heard == [("gain", 0.25, 0.25), ("gain", 1.0, 1.0)]


def test_post_set_callbacks_hear_a_declaration_as_rclpy_s_do(ex: DeterministicExecutor) -> None:
    """A parameter declared after the callback was added is heard, with its value (what
    mirrors it to ROS 2 tools relies on); a refused declaration is not."""
    node = Node("n", context=ex.context, parameter_overrides={"late": 7})
    heard: list[tuple[str, object]] = []
    node.add_post_set_parameters_callback(lambda ps: heard.extend((p.name, p.value) for p in ps))
    node.declare_parameter("late", 1)
    with pytest.raises(ParameterError):
        node.declare_parameter("bad", 2.0, ParameterDescriptor(range=(0.0, 1.0)))
    assert heard == [("late", 7)]


# -- the generic loader: a ROS 2 parameter file into a frozen dataclass ----------------------


class Mode(Enum):
    AUTO = "auto"
    MANUAL = "manual"


@dataclass(frozen=True)
class InnerParams:
    gain: float = param(unit="1/s", range=(0.0, 10.0), lo_open=True)


@dataclass(frozen=True)
class ThingParams:
    rate_hz: int = param(unit="Hz", range=(1, 1000))
    inner: InnerParams
    mode: Mode = Mode.AUTO
    speed: float = param(0.5, unit="m/s", range=(0.0, 2.0))

    def __post_init__(self) -> None:
        validate_parameters(self)
        if self.speed * self.rate_hz > 50.0:
            raise ParameterError(f"{self.speed * self.rate_hz} m/s*Hz is too much", key="speed")


THING = """\
thing:
  ros__parameters:
    rate_hz: 50          # Hz
    inner:
      gain: 2            # 1/s
    mode: manual
other_node:
  ros__parameters:
    anything: 1
"""


def _thing_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "thing.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_loader_reads_types_sections_enums_and_defaults(tmp_path: Path) -> None:
    params = load_parameters(ThingParams, "thing", _thing_file(tmp_path, THING))
    assert params == ThingParams(rate_hz=50, inner=InnerParams(gain=2.0), mode=Mode.MANUAL)
    assert type(params.inner.gain) is float  # an int given to a float field is stored as one
    assert params.speed == 0.5


@pytest.mark.parametrize(
    ("old", "new", "key", "problem"),
    [
        # a key the dataclass does not declare
        ("mode: manual", "mode: manual\n    rate: 3", "thing.rate",
         "unknown key; allowed keys are rate_hz, inner, mode, speed"),
        # a wrong type
        ("rate_hz: 50", "rate_hz: fast", "thing.rate_hz",
         "'fast' must be an integer in the allowed range [1, 1000] Hz"),
        # out of range, also in a nested section and at an open bound
        ("rate_hz: 50", "rate_hz: 5000", "thing.rate_hz",
         "5000 is outside the allowed range [1, 1000] Hz"),
        ("gain: 2", "gain: 0", "thing.inner.gain",
         "0.0 is outside the allowed range (0, 10] 1/s"),
        ("mode: manual", "mode: sideways", "thing.mode", "'sideways' is not one of auto, manual"),
        ("      gain: 2            # 1/s\n", "", "thing.inner.gain",
         "missing; expected a number in the allowed range (0, 10] 1/s"),
        ("mode: manual", "mode: manual\n    speed: 20.0", "thing.speed",
         "20.0 is outside the allowed range [0, 2] m/s"),
        ("mode: manual", "mode: manual\n    speed: 2.0", "thing.speed",
         "100.0 m/s*Hz is too much"),  # a check across fields, in __post_init__
    ],
)
def test_each_bad_value_is_one_error_naming_file_node_and_key(
    tmp_path: Path, old: str, new: str, key: str, problem: str
) -> None:
    path = _thing_file(tmp_path, THING.replace(old, new, 1))
    with pytest.raises(ParameterError) as caught:
        load_parameters(ThingParams, "thing", path)
    error = caught.value
    assert (error.source, error.key, error.problem) == (str(path), key, problem)
    assert str(error) == f"{path}: {key}: {problem}"


def test_a_yaml_syntax_error_is_one_line_naming_the_file_and_the_place(tmp_path: Path) -> None:
    path = _thing_file(tmp_path, THING.replace("rate_hz: 50", "rate_hz: [50"))
    with pytest.raises(ParameterError) as caught:
        load_parameters(ThingParams, "thing", path)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: invalid YAML at line 4, column 5: ")


def test_a_duplicate_key_is_an_error_not_a_silent_override(tmp_path: Path) -> None:
    path = _thing_file(tmp_path, THING.replace("rate_hz: 50", "rate_hz: 50\n    rate_hz: 60"))
    with pytest.raises(ParameterError, match=r"line 4, column 5: duplicate key 'rate_hz'$"):
        load_parameters(ThingParams, "thing", path)


def test_the_file_must_have_the_node_and_its_ros__parameters(tmp_path: Path) -> None:
    with pytest.raises(ParameterError, match=r"thing\.yaml: thing: missing$"):
        load_parameters(ThingParams, "thing",
                        _thing_file(tmp_path, "other:\n  ros__parameters: {}\n"))
    with pytest.raises(ParameterError, match=r"thing: expected a single 'ros__parameters' mapping"):
        parameters_from_yaml(ThingParams, "thing", "thing:\n  params: {}\n")
    with pytest.raises(ParameterError, match=r"nowhere\.yaml: cannot read"):
        load_parameters(ThingParams, "thing", tmp_path / "nowhere.yaml")


def test_built_in_code_the_dataclass_checks_itself() -> None:
    with pytest.raises(ParameterError, match=r"^rate_hz: 0 is outside the allowed range"):
        ThingParams(rate_hz=0, inner=InnerParams(gain=1.0))
    with pytest.raises(ParameterError, match=r"^mode: 'up' is not one of auto, manual$"):
        ThingParams(rate_hz=1, inner=InnerParams(gain=1.0), mode="up")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"^inner\.gain: 0\.0 is outside"):
        ThingParams(rate_hz=1, inner=InnerParams(gain=0.0))


def test_a_param_field_must_have_a_parameter_type() -> None:
    @dataclass(frozen=True)
    class Bad:
        where: object = param()

    with pytest.raises(TypeError, match=r"Bad\.where: a param\(\) field must be"):
        parameter_fields(Bad)


def test_the_config_folder_is_next_to_the_packages_and_can_be_moved(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(CONFIG_DIR_ENV, raising=False)
    assert config_dir() == Path(runtime.__file__).resolve().parent.parent / "config"
    assert (config_dir() / "fcu_link.yaml").is_file()
    monkeypatch.setenv(CONFIG_DIR_ENV, str(tmp_path))
    assert config_path("thing.yaml") == tmp_path / "thing.yaml"
    _thing_file(tmp_path, THING)
    assert load_parameters(ThingParams, "thing").rate_hz == 50  # the default path follows
    ex = DeterministicExecutor()  # and so does a node's YAML
    assert ex.context.config_dir == tmp_path


def test_a_node_declares_sections_and_enums_from_its_yaml(tmp_path: Path) -> None:
    (tmp_path / "thing.yaml").write_text(THING, encoding="utf-8")
    ex = DeterministicExecutor(config_dir=tmp_path)
    node = Node("thing", context=ex.context)
    params = node.declare_params(ThingParams)
    assert params == load_parameters(ThingParams, "thing", tmp_path / "thing.yaml")
    assert node.get_parameter("inner.gain").value == 2.0
    assert node.get_parameter("mode").value == "manual"
    ex.add_node(node)  # every YAML key was declared


def test_a_node_reports_a_bad_nested_value_with_file_node_and_key(tmp_path: Path) -> None:
    (tmp_path / "thing.yaml").write_text(THING.replace("gain: 2", "gain: -1"), encoding="utf-8")
    ex = DeterministicExecutor(config_dir=tmp_path)
    with pytest.raises(ParameterError) as caught:
        Node("thing", context=ex.context).declare_params(ThingParams)
    assert str(caught.value) == (
        f"{tmp_path / 'thing.yaml'}: thing.inner.gain: -1.0 is outside the allowed range "
        "(0, 10] 1/s"
    )
