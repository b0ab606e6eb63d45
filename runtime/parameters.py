"""Parameters, the one system: declared once as a frozen dataclass, values from config/.

A set of parameters is a frozen dataclass. Its annotations are the types (``bool``,
``int``, ``float``, ``str``, ``tuple[X, ...]``, an Enum read from its value, or a nested
parameter dataclass read from a sub-mapping); each field made with :func:`param` carries
its unit and allowed range or choices, and its default when it has one::

    @dataclass(frozen=True)
    class TalkerParams:
        rate_hz: float = param(unit="Hz", range=(0.1, 1000.0))   # no default: from YAML
        mode: Mode = Mode.AUTO                                     # an Enum, "auto" in YAML
        inner: InnerParams = field(default_factory=InnerParams)   # a nested section

        def __post_init__(self) -> None:
            validate_parameters(self)  # checked however it is built; then cross-field checks

The values live in ROS 2 parameter files, one per node, in the config folder
(:func:`config_dir`: ``config/`` next to the packages, or ``$QUADMISSION_CONFIG_DIR``)::

    talker:
      ros__parameters:
        rate_hz: 2.0        # Hz, how often to publish

Two readers share every check here: :func:`load_parameters` reads a whole file into the
dataclass (the simulated FCU's modules), and a :class:`~runtime.node.Node` declares the
fields one by one with :meth:`~runtime.node.Node.declare_params` (launch overrides >
the node's YAML > the default). A value of the wrong type, out of range or not among
the choices, a key nobody declares, a missing required key and a YAML syntax error each
raise one :class:`~runtime.errors.ParameterError` naming the file, the parameter's full
name (node first, ``talker.rate_hz``) and what is allowed.

Pure module: PyYAML only.
"""

from __future__ import annotations

import dataclasses
import os
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, TypeVar

import yaml

from runtime.errors import ParameterError

P = TypeVar("P")

# -- the config folder ------------------------------------------------------------------------

CONFIG_DIR_ENV = "QUADMISSION_CONFIG_DIR"
"""Environment variable that moves the config folder (for an installed package, a site)."""
PACKAGE_CONFIG_DIR = Path(__file__).resolve().parent.parent / "config"
"""``config/`` next to the packages: one YAML per node or firmware module, and arenas/."""


def config_dir() -> Path:
    """The config folder: ``$QUADMISSION_CONFIG_DIR`` if set, else :data:`PACKAGE_CONFIG_DIR`."""
    override = os.environ.get(CONFIG_DIR_ENV)
    return Path(override) if override else PACKAGE_CONFIG_DIR


def config_path(name: str, directory: Path | None = None) -> Path:
    """``name`` (``fcu_link.yaml``, ``arenas/contest.yaml``) in ``directory`` (default: the
    config folder, :func:`config_dir`)."""
    return (directory if directory is not None else config_dir()) / name


# -- YAML -----------------------------------------------------------------------------------


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys (PyYAML keeps the last one silently)."""


def _construct_unique_mapping(loader: _StrictLoader, node: yaml.MappingNode) -> dict[Any, Any]:
    mapping: dict[Any, Any] = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if key in mapping:
            raise yaml.constructor.ConstructorError(
                problem=f"duplicate key {key!r}", problem_mark=key_node.start_mark)
        mapping[key] = loader.construct_object(value_node, deep=True)
    return mapping


_StrictLoader.add_constructor(
    yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_unique_mapping)


def load_yaml(text: str) -> Any:
    """The YAML document in ``text``, read safely and strictly (a duplicate key is an error).

    The project's one YAML reader (parameter files, arenas, launch files, module tables);
    raises ``yaml.YAMLError``: say it with :func:`yaml_syntax_problem`.
    """
    return yaml.load(text, Loader=_StrictLoader)


def yaml_syntax_problem(exc: yaml.YAMLError) -> str:
    """A YAML error as one line: ``invalid YAML at line 3, column 9: <what>``."""
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    return f"invalid YAML{at}: {problem}"


def parse_yaml(text: str, source: str | None = None) -> Any:
    """:func:`load_yaml`; an error is a one-line ParameterError naming ``source``."""
    try:
        return load_yaml(text)
    except yaml.YAMLError as exc:
        raise ParameterError(yaml_syntax_problem(exc), source=source) from None


def read_yaml(path: Path) -> Any:
    """The YAML document in the file ``path``; errors (unreadable, bad syntax) name the file."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ParameterError(f"cannot read: {exc.strerror or exc}", source=str(path)) from None
    return parse_yaml(text, str(path))


# -- types, descriptors and checks ----------------------------------------------------------


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
_WANTED = {
    ParameterType.BOOL: "true or false",
    ParameterType.INTEGER: "an integer",
    ParameterType.DOUBLE: "a number",
    ParameterType.STRING: "a string",
}


@dataclass(frozen=True)
class ParameterDescriptor:
    """What a parameter is: its type, unit, allowed range or choices."""

    type: ParameterType | None = None
    description: str = ""
    unit: str = ""
    range: tuple[float, float] | None = None
    """Bounds for numbers and number arrays: ``[lo, hi]``, or ``(lo, hi]`` if ``lo_open``."""
    lo_open: bool = False
    choices: tuple[Any, ...] | None = None
    read_only: bool = False

    def describe_range(self) -> str:
        """The range as errors show it: ``[0, 10] Hz``, ``(0, 1e+06] mAh``."""
        if self.range is None:
            return "any value"
        lo, hi = (f"{v}" if isinstance(v, int) else f"{v:g}" for v in self.range)
        unit = f" {self.unit}" if self.unit else ""
        return f"{'(' if self.lo_open else '['}{lo}, {hi}]{unit}"

    def allowed(self) -> str:
        """What is allowed, as errors say it."""
        if self.choices is not None:
            return "one of " + ", ".join(str(c) for c in self.choices)
        kind = self.type
        scalar = _SCALAR_OF_ARRAY.get(kind, kind) if kind is not None else None
        what = _WANTED.get(scalar, "a value") if scalar is not None else "a value"
        if kind in _SCALAR_OF_ARRAY:
            what = f"a list of {what.removeprefix('an ').removeprefix('a ')}s"
        return f"{what} in the allowed range {self.describe_range()}" if self.range else what


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


def _coerce_scalar(key: str, kind: ParameterType, value: Any, descriptor: ParameterDescriptor
                   ) -> Any:
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
    raise ParameterError(f"{value!r} must be {descriptor.allowed()}", key=key)


def coerce_value(key: str, kind: ParameterType, value: Any,
                 descriptor: ParameterDescriptor | None = None) -> Any:
    """``value`` as a ``kind`` (int widens to double; lists become tuples), or an error."""
    descriptor = dataclasses.replace(descriptor or ParameterDescriptor(), type=kind)
    scalar = _SCALAR_OF_ARRAY.get(kind)
    if scalar is None:
        return _coerce_scalar(key, kind, value, descriptor)
    if not isinstance(value, list | tuple):
        raise ParameterError(f"{value!r} must be {descriptor.allowed()}", key=key)
    one = dataclasses.replace(descriptor, type=scalar)
    return tuple(_coerce_scalar(f"{key}[{i}]", scalar, v, one) for i, v in enumerate(value))


def check_value(key: str, descriptor: ParameterDescriptor, value: Any) -> None:
    """Range and choices; the ParameterError names the key, the value and what is allowed."""
    if descriptor.range is not None:
        lo, hi = descriptor.range
        items = ((f"{key}[{i}]", v) for i, v in enumerate(value)) if isinstance(
            value, tuple) else ((key, value),)
        for where, v in items:
            if not isinstance(v, int | float):
                continue
            above = v > lo if descriptor.lo_open else v >= lo
            if not (above and v <= hi):  # also rejects NaN
                raise ParameterError(
                    f"{v!r} is outside the allowed range {descriptor.describe_range()}", key=where
                )
    if descriptor.choices is not None and value not in descriptor.choices:
        raise ParameterError(f"{value!r} is not {descriptor.allowed()}", key=key)


# -- parameters as one frozen dataclass ------------------------------------------------------

_META_KEY = "quadmission.parameter"


def param(
    default: Any = dataclasses.MISSING,
    *,
    unit: str = "",
    range: tuple[float, float] | None = None,
    lo_open: bool = False,
    choices: Sequence[Any] | None = None,
    description: str = "",
) -> Any:
    """A dataclass field that is a parameter, with its unit and allowed values.

    ``range`` is ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``), for numbers and number
    arrays. Leave ``default`` out when the YAML under config/ must supply the value (the
    usual case: the YAML is where values live, the dataclass is where types live).
    """
    descriptor = ParameterDescriptor(
        description=description,
        unit=unit,
        range=(range[0], range[1]) if range is not None else None,
        lo_open=lo_open,
        choices=tuple(choices) if choices is not None else None,
    )
    kwargs: dict[str, Any] = {"metadata": {_META_KEY: descriptor}}
    if default is not dataclasses.MISSING:
        kwargs["default"] = default
    return dataclasses.field(**kwargs)


@dataclass(frozen=True)
class ParameterField:
    """One field of a parameter dataclass, as the checks and the readers see it.

    Exactly one of ``kind`` (a scalar or array), ``enum`` and ``section`` (a nested
    parameter dataclass) is set, or none for an annotation the system does not read
    (passed through unchecked).
    """

    name: str
    descriptor: ParameterDescriptor
    default: Any  # dataclasses.MISSING if none (a default_factory counts as a default)
    kind: ParameterType | None = None
    enum: type[Enum] | None = None
    section: type | None = None

    @property
    def required(self) -> bool:
        return self.default is dataclasses.MISSING

    def convert(self, key: str, value: Any) -> Any:
        """``value`` checked and converted to this field's type (a mapping read into a section)."""
        if self.kind is not None:
            coerced = coerce_value(key, self.kind, value, self.descriptor)
            check_value(key, self.descriptor, coerced)
            return coerced
        if self.enum is not None:
            if isinstance(value, self.enum):
                return value
            try:
                return self.enum(value)
            except ValueError:
                allowed = ", ".join(str(m.value) for m in self.enum)
                raise ParameterError(f"{value!r} is not one of {allowed}", key=key) from None
        if self.section is not None and not isinstance(value, self.section):
            return build_parameters(self.section, value, key)
        return value


def _type_of_annotation(annotation: Any) -> ParameterType | None:
    if annotation in _PY_TYPES:
        return _PY_TYPES[annotation]
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis and args[0] in _PY_TYPES:
        scalar = _PY_TYPES[args[0]]
        for array, kind in _SCALAR_OF_ARRAY.items():
            if kind is scalar:
                return array
    return None


_FIELDS: dict[type, tuple[ParameterField, ...]] = {}  # memo: a class's fields never change


def parameter_fields(cls: type) -> tuple[ParameterField, ...]:
    """The fields of the parameter dataclass ``cls``."""
    if cls in _FIELDS:
        return _FIELDS[cls]
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        raise TypeError(f"{cls!r} is not a dataclass")
    hints = typing.get_type_hints(cls)
    fields = []
    for f in dataclasses.fields(cls):
        annotation = hints[f.name]
        descriptor: ParameterDescriptor = f.metadata.get(_META_KEY, ParameterDescriptor())
        kind = _type_of_annotation(annotation)
        enum = annotation if isinstance(annotation, type) and issubclass(annotation, Enum) else None
        section = annotation if (isinstance(annotation, type) and dataclasses.is_dataclass(
            annotation)) else None
        if _META_KEY in f.metadata and kind is None:
            raise TypeError(f"{cls.__name__}.{f.name}: a param() field must be bool, int, "
                            f"float, str or tuple[X, ...], not {annotation!r}")
        default: Any = f.default
        if f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        fields.append(ParameterField(
            f.name, dataclasses.replace(descriptor, type=kind), default, kind, enum, section))
    _FIELDS[cls] = tuple(fields)
    return _FIELDS[cls]


def validate_parameters(obj: object) -> None:
    """Check every typed field of the parameter dataclass ``obj`` (type, range, choices),
    nested sections included.

    Raises ParameterError naming the field and what is allowed; stores the ``int`` given
    to a ``float`` field as a float and a list as a tuple. Call it first in
    ``__post_init__``, then check anything across fields.
    """
    for f in parameter_fields(type(obj)):
        value = getattr(obj, f.name)
        if f.section is not None:
            if not isinstance(value, f.section):
                raise ParameterError(f"expected a {f.section.__name__}, got {value!r}",
                                     key=f.name)
            try:
                validate_parameters(value)  # a section built in code without its own check
            except ParameterError as exc:
                raise exc.prefixed(f.name) from None
            continue
        converted = f.convert(f.name, value)
        if converted is not value:
            object.__setattr__(obj, f.name, converted)


# -- reading ROS 2 parameter files ----------------------------------------------------------

ROS_PARAMETERS = "ros__parameters"
_ABSENT = object()


def _mapping(value: object, key: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ParameterError(f"expected a mapping, got {type(value).__name__}", key=key)
    return value


def node_section(doc: object, node_name: str) -> Mapping[str, Any] | None:
    """The ``ros__parameters`` of ``node_name`` in a parsed parameter file (``/**`` entries
    first, then the node's own, shallow-merged); None when the file has none for it."""
    top = _mapping({} if doc is None else doc, "")
    bare = node_name.lstrip("/")
    merged: dict[str, Any] | None = None
    for name in ("/**", bare, f"/{bare}"):
        if name not in top:
            continue
        entry = _mapping(top[name], bare)
        if ROS_PARAMETERS not in entry or set(entry) != {ROS_PARAMETERS}:
            keys = ", ".join(str(k) for k in entry) or "none"
            raise ParameterError(f"expected a single {ROS_PARAMETERS!r} mapping, found keys: "
                                 f"{keys}", key=bare)
        merged = {**(merged or {}), **_mapping(entry[ROS_PARAMETERS] or {}, bare)}
    return merged


def _needs_keys(cls: type) -> bool:
    """Whether a section read into ``cls`` must have some key (it cannot be left out)."""
    return any(_needs_keys(f.section) if f.section is not None else f.required
               for f in parameter_fields(cls))


def build_parameters(cls: type[P], value: object, key: str) -> P:
    """``cls`` from the mapping ``value`` whose parameters are named ``key.<field>``.

    Keys of ``value`` that ``cls`` does not declare, missing required keys, and values of
    the wrong type, out of range or not among the choices raise ParameterError.
    """
    fields = parameter_fields(cls)
    if value is _ABSENT:
        if _needs_keys(cls):
            raise ParameterError("missing", key=key)
        value = {}
    elif value is None:  # written but empty (``inner:``)
        value = {}
    section = _mapping(value, key)
    names = [f.name for f in fields]
    for name in section:
        if name not in names:
            raise ParameterError(f"unknown key; allowed keys are {', '.join(names)}",
                                 key=f"{key}.{name}")
    values: dict[str, Any] = {}
    for f in fields:
        where = f"{key}.{f.name}"
        item = section.get(f.name, _ABSENT)
        if f.section is not None:
            values[f.name] = build_parameters(f.section, item, where)
        elif item is _ABSENT:
            if f.required:
                raise ParameterError(f"missing; expected {f.descriptor.allowed()}", key=where)
        else:
            values[f.name] = f.convert(where, item)
    try:
        return cls(**values)
    except ParameterError as exc:  # a check across fields in __post_init__
        raise exc.prefixed(key) from None


def parameters_from_mapping(cls: type[P], node_name: str, doc: object,
                            source: str | None = None) -> P:
    """``cls`` from a parsed ROS 2 parameter file ``{node_name: {ros__parameters: {...}}}``.

    Other nodes' sections are ignored. Errors name ``source`` (the file), when given, and
    the parameter's full name, node first (``fcu_link.to_fcu.baud_rate``).
    """
    try:
        section = node_section(doc, node_name)
        if section is None and _needs_keys(cls):
            raise ParameterError("missing", key=node_name)
        return build_parameters(cls, section, node_name)
    except ParameterError as exc:
        raise (exc.with_source(source) if source else exc) from None


def parameters_from_yaml(cls: type[P], node_name: str, text: str,
                         source: str | None = None) -> P:
    """:func:`parameters_from_mapping` on YAML text; ``source`` names the file in errors."""
    return parameters_from_mapping(cls, node_name, parse_yaml(text, source), source)


def load_parameters(cls: type[P], node_name: str, path: Path | None = None) -> P:
    """``cls`` from the file ``path`` (default: ``<node_name>.yaml`` in the config folder)."""
    path = path if path is not None else config_path(f"{node_name}.yaml")
    return parameters_from_mapping(cls, node_name, read_yaml(path), str(path))


def _flatten(prefix: str, tree: Mapping[str, Any], out: dict[str, Any]) -> None:
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            _flatten(f"{name}.", value, out)
        else:
            out[name] = value


def load_node_yaml(path: Path, node_name: str) -> dict[str, Any]:
    """The parameters for ``node_name`` in a ROS 2 parameter file, nested keys joined by
    dots (``to_fcu.baud_rate``), for a node to declare one by one. Missing file: none."""
    if not path.is_file():
        return {}
    try:
        section = node_section(read_yaml(path), node_name)
    except ParameterError as exc:
        raise exc.with_source(str(path)) from None
    params: dict[str, Any] = {}
    _flatten("", section or {}, params)
    return params


def is_missing(value: Any) -> bool:
    return value is dataclasses.MISSING


__all__ = [
    "CONFIG_DIR_ENV",
    "PACKAGE_CONFIG_DIR",
    "ROS_PARAMETERS",
    "Parameter",
    "ParameterDescriptor",
    "ParameterError",
    "ParameterField",
    "ParameterType",
    "SetParametersResult",
    "build_parameters",
    "check_value",
    "coerce_value",
    "config_dir",
    "config_path",
    "is_missing",
    "load_node_yaml",
    "load_parameters",
    "load_yaml",
    "node_section",
    "param",
    "parameter_fields",
    "parameters_from_mapping",
    "parameters_from_yaml",
    "parse_yaml",
    "read_yaml",
    "type_of_value",
    "validate_parameters",
    "yaml_syntax_problem",
]
