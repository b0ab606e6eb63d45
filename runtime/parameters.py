"""Typed, range-checked node parameters, with values from the node's YAML under config/.

A node's YAML is ``config/<node_name>.yaml`` in ROS 2's format::

    talker:
      ros__parameters:
        rate_hz: 2.0        # Hz, how often to publish

Precedence: launch overrides > the node's YAML > the default given in code. A value of
the wrong type, out of its range or not among its choices raises ParameterError naming
the node, the key and the allowed values; so does a YAML key that the node never
declares (checked when the node joins an executor).

A node can declare its parameters as one frozen dataclass whose fields carry the unit
and range (``param(unit="m/s", range=(0.1, 2.0))``) and get a validated instance back.
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, TypeVar

import yaml

from runtime.errors import ParameterError

T = TypeVar("T")


class ParameterType(Enum):
    BOOL = "bool"
    INTEGER = "int"
    DOUBLE = "double"
    STRING = "string"
    BOOL_ARRAY = "bool[]"
    INTEGER_ARRAY = "int[]"
    DOUBLE_ARRAY = "double[]"
    STRING_ARRAY = "string[]"


_SCALAR_OF_ARRAY = {
    ParameterType.BOOL_ARRAY: ParameterType.BOOL,
    ParameterType.INTEGER_ARRAY: ParameterType.INTEGER,
    ParameterType.DOUBLE_ARRAY: ParameterType.DOUBLE,
    ParameterType.STRING_ARRAY: ParameterType.STRING,
}
_PY_TYPES: dict[Any, ParameterType] = {
    bool: ParameterType.BOOL,
    int: ParameterType.INTEGER,
    float: ParameterType.DOUBLE,
    str: ParameterType.STRING,
}


@dataclass(frozen=True)
class ParameterDescriptor:
    """What a parameter is: its type, unit, allowed range or choices."""

    type: ParameterType | None = None
    description: str = ""
    unit: str = ""
    range: tuple[float, float] | None = None  # inclusive bounds, for numbers and arrays
    choices: tuple[Any, ...] | None = None
    read_only: bool = False


@dataclass(frozen=True)
class Parameter:
    name: str
    type: ParameterType
    value: Any


@dataclass(frozen=True)
class SetParametersResult:
    successful: bool
    reason: str = ""


def type_of_value(value: Any) -> ParameterType | None:
    """The parameter type a Python value has, or None if it has none."""
    if isinstance(value, bool):
        return ParameterType.BOOL
    if isinstance(value, int):
        return ParameterType.INTEGER
    if isinstance(value, float):
        return ParameterType.DOUBLE
    if isinstance(value, str):
        return ParameterType.STRING
    if isinstance(value, list | tuple) and value:
        kinds = {type_of_value(v) for v in value}
        if kinds == {ParameterType.INTEGER, ParameterType.DOUBLE}:
            return ParameterType.DOUBLE_ARRAY
        if len(kinds) == 1:
            kind = kinds.pop()
            for array, scalar in _SCALAR_OF_ARRAY.items():
                if scalar is kind:
                    return array
    return None


def _coerce_scalar(where: str, kind: ParameterType, value: Any) -> Any:
    if kind is ParameterType.BOOL and isinstance(value, bool):
        return value
    if kind is ParameterType.INTEGER and isinstance(value, int) and not isinstance(value, bool):
        return value
    if kind is ParameterType.DOUBLE and isinstance(value, int | float) and not isinstance(
        value, bool
    ):
        return float(value)
    if kind is ParameterType.STRING and isinstance(value, str):
        return value
    raise ParameterError(f"{where}: expected {kind.value}, got {value!r} ({type(value).__name__})")


def coerce_value(where: str, kind: ParameterType, value: Any) -> Any:
    """``value`` as a ``kind`` (int widens to double; lists become tuples), or an error."""
    scalar = _SCALAR_OF_ARRAY.get(kind)
    if scalar is None:
        return _coerce_scalar(where, kind, value)
    if not isinstance(value, list | tuple):
        raise ParameterError(f"{where}: expected a list of {scalar.value}, got {value!r}")
    return tuple(_coerce_scalar(f"{where}[{i}]", scalar, v) for i, v in enumerate(value))


def check_value(where: str, descriptor: ParameterDescriptor, value: Any) -> None:
    """Range and choices; ParameterError names the key, the value and what is allowed."""
    unit = f" {descriptor.unit}" if descriptor.unit else ""
    if descriptor.range is not None:
        lo, hi = descriptor.range
        values = value if isinstance(value, tuple) else (value,)
        for v in values:
            if isinstance(v, int | float) and not lo <= v <= hi:
                raise ParameterError(f"{where}: {v}{unit} is outside the range [{lo}, {hi}]{unit}")
    if descriptor.choices is not None and value not in descriptor.choices:
        raise ParameterError(f"{where}: {value!r} is not one of {list(descriptor.choices)}")


def _flatten(prefix: str, tree: Mapping[str, Any], out: dict[str, Any]) -> None:
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            _flatten(f"{name}.", value, out)
        else:
            out[name] = value


def load_node_yaml(path: Path, node_name: str) -> dict[str, Any]:
    """The parameters for ``node_name`` in a ROS 2 parameter file (nested keys joined by
    dots); ``/**`` entries apply to every node. Missing file: no parameters."""
    if not path.is_file():
        return {}
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except yaml.YAMLError as exc:
        raise ParameterError(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(doc, Mapping):
        raise ParameterError(f"{path}: expected a mapping of node names at the top level")
    params: dict[str, Any] = {}
    bare = node_name.lstrip("/")
    for key in ("/**", bare, f"/{bare}"):
        entry = doc.get(key)
        if entry is None:
            continue
        if not isinstance(entry, Mapping) or "ros__parameters" not in entry:
            raise ParameterError(f"{path}: {key}: expected a 'ros__parameters' mapping")
        extra = sorted(set(entry) - {"ros__parameters"})
        if extra:
            raise ParameterError(f"{path}: {key}: unknown key {extra[0]!r}")
        section = entry["ros__parameters"] or {}
        if not isinstance(section, Mapping):
            raise ParameterError(f"{path}: {key}.ros__parameters: expected a mapping")
        _flatten("", section, params)
    return params


# -- parameters as one frozen dataclass ------------------------------------------------------

_META_KEY = "quadmission.parameter"


def param(
    default: Any = dataclasses.MISSING,
    *,
    description: str = "",
    unit: str = "",
    range: tuple[float, float] | None = None,
    choices: Sequence[Any] | None = None,
) -> Any:
    """A dataclass field that is a node parameter, with its unit and allowed values.

    Leave ``default`` out when the node's YAML under config/ must supply the value (the
    usual case: the YAML is where values live, the dataclass is where types live).
    """
    descriptor = ParameterDescriptor(
        description=description,
        unit=unit,
        range=range,
        choices=tuple(choices) if choices is not None else None,
    )
    kwargs: dict[str, Any] = {"metadata": {_META_KEY: descriptor}}
    if default is not dataclasses.MISSING:
        kwargs["default"] = default
    return dataclasses.field(**kwargs)


def _type_of_annotation(where: str, annotation: Any) -> ParameterType:
    if annotation in _PY_TYPES:
        return _PY_TYPES[annotation]
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis and args[0] in _PY_TYPES:
        scalar = _PY_TYPES[args[0]]
        for array, kind in _SCALAR_OF_ARRAY.items():
            if kind is scalar:
                return array
    raise ParameterError(
        f"{where}: parameter type {annotation!r} is not supported "
        "(use bool, int, float, str or tuple[X, ...])"
    )


def dataclass_descriptors(cls: type) -> dict[str, tuple[ParameterDescriptor, Any]]:
    """Each field's descriptor (with its type filled in) and default (MISSING if none)."""
    if not dataclasses.is_dataclass(cls):
        raise ParameterError(f"{cls!r} is not a dataclass")
    hints = typing.get_type_hints(cls)
    out: dict[str, tuple[ParameterDescriptor, Any]] = {}
    for f in dataclasses.fields(cls):
        base = f.metadata.get(_META_KEY, ParameterDescriptor())
        kind = _type_of_annotation(f"{cls.__name__}.{f.name}", hints[f.name])
        default: Any = f.default
        out[f.name] = (dataclasses.replace(base, type=kind), default)
    return out


def is_missing(value: Any) -> bool:
    return value is dataclasses.MISSING


__all__ = [
    "Parameter",
    "ParameterDescriptor",
    "ParameterError",
    "ParameterType",
    "SetParametersResult",
    "check_value",
    "coerce_value",
    "dataclass_descriptors",
    "is_missing",
    "load_node_yaml",
    "param",
    "type_of_value",
]
