"""Parameters of the simulated FCU's modules: declared once, read from a ROS 2 parameter file.

A configurable module declares its parameters as a frozen dataclass. Each numeric field
is a :func:`param`: its type is the annotation (``int`` or ``float``), its allowed range
and unit (and default, if it has one) are declared on the field, once::

    @dataclass(frozen=True, slots=True)
    class ThingParams:
        rate_hz: int = param(1, 1000, "Hz", default=50)
        gain: float = param(0.0, 10.0, "1/s", lo_open=True)  # no default: required
        mode: ThingMode = ThingMode.AUTO  # an Enum: read from its value, e.g. "auto"
        inner: InnerParams = field(default_factory=InnerParams)  # a nested section

        def __post_init__(self) -> None:
            validate_parameters(self)  # then any check across fields

:func:`validate_parameters` checks every :func:`param` field (type, range; a ``float``
field given an ``int`` is stored as a float) and every Enum field, so the dataclass is
checked however it is built. :func:`load_parameters`, :func:`parameters_from_yaml` and
:func:`parameters_from_mapping` read ``<node_name>: ros__parameters: {...}``, one key per
field, a nested mapping per nested dataclass field. Unknown keys are errors; a missing
key is an error when its field has no default, and a missing section is read as empty
unless some key in it is required. Every error is a
:class:`~sim.fcu.errors.FcuParameterError` naming the full key path (and the file, when
given) and, for a value out of range, the allowed range and unit.

Pure module: PyYAML only.
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any, TypeVar

import yaml

from sim.fcu.errors import FcuParameterError

__all__ = [
    "ParamRange",
    "load_parameters",
    "param",
    "parameters_from_mapping",
    "parameters_from_yaml",
    "validate_parameters",
]

P = TypeVar("P")

_ROS_PARAMETERS = "ros__parameters"


@dataclass(frozen=True, slots=True)
class ParamRange:
    """Allowed range ``[lo, hi]`` (``(lo, hi]`` when ``lo_open``) and unit of one parameter."""

    lo: float
    hi: float
    unit: str = ""
    lo_open: bool = False

    def describe(self, kind: type) -> str:
        """The range as errors show it: ``[0, 10] Hz``, ``(0, 1e+06] mAh``."""
        lo, hi = (int(self.lo), int(self.hi)) if kind is int else (f"{self.lo:g}", f"{self.hi:g}")
        unit = f" {self.unit}" if self.unit else ""
        return f"{'(' if self.lo_open else '['}{lo}, {hi}]{unit}"

    def check(self, key: str, kind: type, value: object) -> None:
        """Raise FcuParameterError under ``key`` unless ``value`` is a ``kind`` in range."""
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or (kind is int and not isinstance(value, int))
        ):
            what = "an integer" if kind is int else "a number"
            raise FcuParameterError(
                key, f"{value!r} must be {what} in the allowed range {self.describe(kind)}"
            )
        above = value > self.lo if self.lo_open else value >= self.lo
        if not (above and value <= self.hi):  # also rejects NaN
            raise FcuParameterError(
                key, f"{value!r} is outside the allowed range {self.describe(kind)}"
            )


def param(
    lo: float,
    hi: float,
    unit: str = "",
    *,
    default: Any = MISSING,
    lo_open: bool = False,
) -> Any:
    """A parameter field: allowed range ``[lo, hi]`` (``(lo, hi]`` if ``lo_open``) and unit.

    Its type is the field's annotation, ``int`` or ``float``. Without ``default`` the
    field is required, in code and in the parameter file.
    """
    return field(default=default, metadata={"range": ParamRange(lo, hi, unit, lo_open)})


@dataclass(frozen=True, slots=True)
class _FieldSpec:
    """What the validator and the loader need to know about one dataclass field."""

    name: str
    kind: type
    range: ParamRange | None
    required: bool  # no default

    @property
    def enum(self) -> type[Enum] | None:
        return self.kind if issubclass(self.kind, Enum) else None

    @property
    def section(self) -> type | None:
        """The nested parameter dataclass read from a sub-mapping, if the field is one."""
        return self.kind if dataclasses.is_dataclass(self.kind) else None


_SPECS: dict[type, tuple[_FieldSpec, ...]] = {}  # memo: a class's fields never change


def _specs(cls: type) -> tuple[_FieldSpec, ...]:
    if cls in _SPECS:
        return _SPECS[cls]
    hints = typing.get_type_hints(cls)
    specs = []
    for f in dataclasses.fields(cls):
        kind = hints[f.name]
        spec_range = f.metadata.get("range")
        if spec_range is not None and kind not in (int, float):
            raise TypeError(f"{cls.__name__}.{f.name}: a param() field must be int or float")
        specs.append(
            _FieldSpec(
                name=f.name,
                kind=kind if isinstance(kind, type) else object,
                range=spec_range,
                required=f.default is MISSING and f.default_factory is MISSING,
            )
        )
    _SPECS[cls] = tuple(specs)
    return _SPECS[cls]


def _allowed(kind: type[Enum]) -> str:
    return ", ".join(str(m.value) for m in kind)


def validate_parameters(obj: object) -> None:
    """Check every :func:`param` and Enum field of the parameter dataclass ``obj``.

    Raises FcuParameterError naming the field and what is allowed; stores the ``int``
    given to a ``float`` field as a float. Call it first in ``__post_init__``.
    """
    for spec in _specs(type(obj)):
        value = getattr(obj, spec.name)
        if spec.range is not None:
            spec.range.check(spec.name, spec.kind, value)
            if spec.kind is float and type(value) is not float:
                object.__setattr__(obj, spec.name, float(value))
        elif (kind := spec.enum) is not None and not isinstance(value, kind):
            raise FcuParameterError(spec.name, f"{value!r} is not one of {_allowed(kind)}")


def _mapping(value: object, key: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise FcuParameterError(key, f"expected a mapping, got {type(value).__name__}")
    return value


def _only_keys(section: Mapping[str, Any], allowed: Sequence[str], key: str) -> None:
    for name in section:
        if name not in allowed:
            raise FcuParameterError(
                f"{key}.{name}", f"unknown key; allowed keys are {', '.join(allowed)}"
            )


_ABSENT = object()


def _needs_keys(cls: type) -> bool:
    """Whether a section read into ``cls`` must have some key (it cannot be left out)."""
    return any(_needs_keys(s.section) if s.section is not None else s.required for s in _specs(cls))


def _build(cls: type[P], value: object, key: str) -> P:
    """``cls`` from the mapping ``value`` found at ``key``; ``_ABSENT`` if there was none."""
    specs = _specs(cls)
    if value is _ABSENT:
        if _needs_keys(cls):
            raise FcuParameterError(key, "missing")
        value = {}
    section = _mapping(value, key)
    _only_keys(section, [s.name for s in specs], key)
    values: dict[str, Any] = {}
    for spec in specs:
        where = f"{key}.{spec.name}"
        item = section.get(spec.name, _ABSENT)
        if (nested := spec.section) is not None:
            values[spec.name] = _build(nested, item, where)
        elif item is _ABSENT:
            if spec.required:
                raise FcuParameterError(where, "missing")
        elif (kind := spec.enum) is not None and not isinstance(item, kind):
            try:
                values[spec.name] = kind(item)
            except ValueError:
                raise FcuParameterError(where, f"{item!r} is not one of {_allowed(kind)}") from None
        else:
            values[spec.name] = item
    try:
        return cls(**values)
    except FcuParameterError as exc:
        raise exc.prefixed(key) from None


def parameters_from_mapping(
    cls: type[P], node_name: str, doc: object, source: str | None = None
) -> P:
    """``cls`` from a parsed ROS 2 parameter file ``{node_name: {ros__parameters: {...}}}``.

    Other nodes' sections are ignored. Errors name the key path (``node_name.
    ros__parameters.section.key``) and, when given, the file ``source``.
    """
    try:
        top = _mapping(doc, "")
        if node_name not in top:
            raise FcuParameterError(node_name, "missing")
        node = _mapping(top[node_name], node_name)
        _only_keys(node, (_ROS_PARAMETERS,), node_name)
        values = node.get(_ROS_PARAMETERS, _ABSENT)
        return _build(cls, values, f"{node_name}.{_ROS_PARAMETERS}")
    except FcuParameterError as exc:
        raise (exc.with_source(source) if source else exc) from None


def parameters_from_yaml(cls: type[P], node_name: str, text: str, source: str | None = None) -> P:
    """:func:`parameters_from_mapping` on YAML text; ``source`` names the file in errors."""
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise FcuParameterError("", f"not valid YAML: {exc}", source) from None
    return parameters_from_mapping(cls, node_name, doc, source)


def load_parameters(cls: type[P], node_name: str, path: Path) -> P:
    """:func:`parameters_from_yaml` on the file ``path`` (UTF-8), named in errors."""
    return parameters_from_yaml(cls, node_name, path.read_text(encoding="utf-8"), str(path))
