"""Typed access to message, service and action types, defaults, validation and CDR."""

from __future__ import annotations

import functools
import keyword
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype

from interfaces.errors import MessageError, UnknownTypeError
from interfaces.registry import CANCEL_GOAL, build_typestore

# dtype of each ROS base type that rosbags stores as a numpy array in arrays/sequences
NUMPY_DTYPES: dict[str, type[np.generic]] = {
    "bool": np.bool_,
    "byte": np.uint8,
    "char": np.uint8,
    "int8": np.int8,
    "uint8": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}
_INT_RANGES: dict[str, tuple[int, int]] = {
    name: (int(np.iinfo(np.dtype(dt)).min), int(np.iinfo(np.dtype(dt)).max))
    for name, dt in NUMPY_DTYPES.items()
    if np.issubdtype(dt, np.integer)
}


@functools.cache
def typestore() -> Any:
    """The shared typestore (ROS 2 Jazzy plus px4_msgs and quadmission_interfaces)."""
    return build_typestore()


def _normalise(name: str, kind: str) -> str:
    parts = name.strip("/").split("/")
    if len(parts) == 2:
        return f"{parts[0]}/{kind}/{parts[1]}"
    return "/".join(parts)


def _fielddefs(typename: str) -> tuple[list[Any], list[Any]]:
    try:
        return typestore().fielddefs[typename]
    except KeyError:
        raise UnknownTypeError(f"unknown message type {typename!r}") from None


def get_message(name: str) -> type:
    """The message class for ``pkg/msg/Name`` (``pkg/Name`` is accepted too)."""
    typename = _normalise(name, "msg")
    try:
        return typestore().types[typename]
    except KeyError:
        raise UnknownTypeError(f"unknown message type {name!r}") from None


@dataclass(frozen=True)
class ServiceType:
    """A service: its name and its request and response message classes."""

    name: str
    Request: type
    Response: type


@dataclass(frozen=True)
class ActionType:
    """An action: goal, result, feedback, and the ROS 2 types composed around them."""

    name: str
    Goal: type
    Result: type
    Feedback: type
    SendGoal: ServiceType
    GetResult: ServiceType
    FeedbackMessage: type


def get_service(name: str) -> ServiceType:
    """The service type ``pkg/srv/Name`` (``pkg/Name`` is accepted too)."""
    typename = _normalise(name, "srv")
    types = typestore().types
    if f"{typename}_Request" not in types:
        raise UnknownTypeError(f"unknown service type {name!r}")
    return ServiceType(typename, types[f"{typename}_Request"], types[f"{typename}_Response"])


def get_action(name: str) -> ActionType:
    """The action type ``pkg/action/Name`` (``pkg/Name`` is accepted too)."""
    typename = _normalise(name, "action")
    types = typestore().types
    if f"{typename}_Goal" not in types:
        raise UnknownTypeError(f"unknown action type {name!r}")

    def svc(part: str) -> ServiceType:
        return ServiceType(
            f"{typename}_{part}",
            types[f"{typename}_{part}_Request"],
            types[f"{typename}_{part}_Response"],
        )

    return ActionType(
        typename,
        types[f"{typename}_Goal"],
        types[f"{typename}_Result"],
        types[f"{typename}_Feedback"],
        svc("SendGoal"),
        svc("GetResult"),
        types[f"{typename}_FeedbackMessage"],
    )


def cancel_goal_service() -> ServiceType:
    """action_msgs/srv/CancelGoal, used by every action."""
    return get_service(CANCEL_GOAL)


def type_name(msg_or_class: Any) -> str:
    """The full type name of a message instance or class."""
    try:
        return str(msg_or_class.__msgtype__)
    except AttributeError:
        raise MessageError(f"{msg_or_class!r} is not a message") from None


def _default(node: tuple[Any, Any]) -> Any:
    kind, arg = node
    if kind == Nodetype.BASE:
        base = arg[0]
        if base == "string" or base == "wstring":
            return ""
        if base == "bool":
            return False
        if base in ("float32", "float64"):
            return 0.0
        return 0
    if kind == Nodetype.NAME:
        return new(arg)
    sub, length = arg
    if sub[0] == Nodetype.BASE and sub[1][0] in NUMPY_DTYPES:
        return np.zeros(length if kind == Nodetype.ARRAY else 0, dtype=NUMPY_DTYPES[sub[1][0]])
    if kind == Nodetype.ARRAY:
        return [_default(sub) for _ in range(length)]
    return []


def _coerce(path: str, node: tuple[Any, Any], value: Any) -> Any:
    """Accept lists/tuples for numeric arrays and sequences, as users write them.

    Each element is checked first, so a float is never truncated into an integer array
    and an out-of-range value raises MessageError naming the element, not OverflowError.
    """
    kind, arg = node
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE) and isinstance(value, list | tuple):
        sub = arg[0]
        if sub[0] == Nodetype.BASE and sub[1][0] in NUMPY_DTYPES:
            for i, item in enumerate(value):
                _check_base(f"{path}[{i}]", sub[1][0], 0, item)
            return np.asarray(value, dtype=NUMPY_DTYPES[sub[1][0]])
        return list(value)
    return value


@dataclass(frozen=True)
class _Layout:
    """A message type's cached field table and the constructor and validator generated
    from it (straight-line code per type: each field's default, coercion and fast check
    inline, as ``dataclasses`` generates ``__init__``)."""

    cls: type
    known: frozenset[str]
    construct: Any  # (**fields) -> message
    check: Any  # (msg, where) -> None; MessageError names the bad field
    generated: bool  # construct is generated code: TypeError on an unknown keyword


_MISSING = object()


def _default_maker(node: tuple[Any, Any]) -> Any:
    """A no-argument function returning a fresh default for ``node``."""
    kind, arg = node
    if kind == Nodetype.BASE:
        value = _default(node)
        return lambda: value
    if kind == Nodetype.NAME:
        return lambda: new(arg)
    sub, length = arg
    if sub[0] == Nodetype.BASE and sub[1][0] in NUMPY_DTYPES:
        dtype, size = NUMPY_DTYPES[sub[1][0]], length if kind == Nodetype.ARRAY else 0
        return lambda: np.zeros(size, dtype=dtype)
    return lambda: _default(node)


def _fast_check_expr(node: tuple[Any, Any], env: dict[str, Any], i: int) -> str | None:
    """A Python expression of ``v`` true for the common, valid values of ``node`` (names
    it needs go in ``env``); anything it refuses goes through :func:`_check`, which raises
    the precise error (or accepts). None: no fast check (nested: validated recursively)."""
    kind, arg = node
    if kind == Nodetype.BASE:
        base, bound = arg
        if base == "float64":
            return "type(v) is float"
        if base == "float32":
            return "(type(v) is float and not abs(v) > 3.4028235e38)"
        if base in _INT_RANGES:
            lo, hi = _INT_RANGES[base]
            return f"(type(v) is int and {lo} <= v <= {hi})"
        if base == "bool":
            return "type(v) is bool"
        if base in ("string", "wstring"):
            return f"(type(v) is str and len(v) <= {bound})" if bound else "type(v) is str"
        return None
    if kind == Nodetype.NAME:
        return None
    sub, length = arg
    if sub[0] == Nodetype.BASE and sub[1][0] in NUMPY_DTYPES:
        env[f"dt{i}"] = np.dtype(NUMPY_DTYPES[sub[1][0]])
        common = f"type(v) is ndarray and v.dtype == dt{i} and v.ndim == 1"
        if kind == Nodetype.ARRAY:
            return f"({common} and len(v) == {length})"
        return f"({common} and len(v) <= {length})" if length else f"({common})"
    return None


def _generate(typename: str, defs: list[Any]) -> tuple[Any, Any]:
    """The constructor and the validator of ``typename`` (see :class:`_Layout`)."""
    names = [fname for fname, _ in defs]
    env: dict[str, Any] = {"cls": typestore().types[typename], "M": _MISSING,
                           "ndarray": np.ndarray, "validate": validate, "_check": _check,
                           # for the constructor, whose parameters are the field names (a
                           # field may be called ``type``; none starts with ``_`` in ROS 2)
                           "_type": type, "_ndarray": np.ndarray}
    if not all(n.isidentifier() and not keyword.iskeyword(n) for n in names):
        return None, None  # not expressible as parameters: the generic path
    args, checks = [], []
    for i, (fname, node) in enumerate(defs):
        kind, arg = node
        env[f"n{i}"] = node
        if kind == Nodetype.BASE:
            env[f"d{i}"] = _default(node)
            args.append(f"{fname}=d{i} if {fname} is M else {fname}")
        else:
            env[f"z{i}"] = _default_maker(node)
            coerce = kind != Nodetype.NAME
            if coerce:
                env[f"c{i}"] = functools.partial(_coerce, f"{typename}.{fname}", node)
            # an array given as an ndarray goes straight to the check: only lists and
            # tuples are coerced (the common case costs no call)
            value = f"({fname} if _type({fname}) is _ndarray else c{i}({fname}))" if (
                coerce) else fname
            args.append(f"{fname}=z{i}() if {fname} is M else {value}")
        fast = _fast_check_expr(node, env, i)
        checks.append(f"    v = msg.{fname}")
        if kind == Nodetype.NAME:
            env[f"t{i}"] = arg
            checks.append(f"    validate(v, t{i}, where + '.{fname}')")
        elif fast is None:
            checks.append(f"    _check(where + '.{fname}', n{i}, v)")
        else:
            checks.append(f"    if not {fast}:\n        _check(where + '.{fname}', n{i}, v)")
    params = ", ".join(f"{n}=M" for n in names)
    body = ",\n        ".join(args)
    source = (f"def construct(*, {params}):\n    return cls(\n        {body})\n\n"
              if names else "def construct():\n    return cls()\n\n")
    source += "def check(msg, where):\n" + ("\n".join(checks) if checks else "    pass") + "\n"
    exec(compile(source, f"<interfaces {typename}>", "exec"), env)
    return env["construct"], env["check"]


@functools.cache
def _layout(typename: str) -> _Layout:
    _, defs = _fielddefs(typename)
    construct, check = _generate(typename, defs)
    generated = construct is not None
    if construct is None:
        fields = tuple((fname, node, _default_maker(node)) for fname, node in defs)
        cls = typestore().types[typename]

        def construct(**given: Any) -> Any:
            return cls(**{f: _coerce(f"{typename}.{f}", n, given[f]) if f in given else make()
                          for f, n, make in fields})

        def check(msg: Any, where: str) -> None:
            for fname, node in defs:
                _check(f"{where}.{fname}", node, getattr(msg, fname))

    return _Layout(
        cls=typestore().types[typename],
        known=frozenset(fname for fname, _ in defs),
        construct=construct,
        check=check,
        generated=generated,
    )


@functools.cache
def _normalised_msg(name: str) -> str:
    return _normalise(name, "msg")


_CONSTRUCTORS: dict[str, Any] = {}
"""Generated constructors by the type name callers wrote: the common case of :func:`new` is
one dictionary lookup and one call (an unknown keyword is a TypeError there)."""


def new(type_or_name: type | str, **fields: Any) -> Any:
    """Build a message with every field not given set to its ROS default (0, "", zeros...).

    Raises MessageError naming the field when a keyword is not a field of the type.
    """
    construct = _CONSTRUCTORS.get(type_or_name) if isinstance(type_or_name, str) else None
    if construct is not None:
        try:
            return construct(**fields)
        except TypeError:
            if _layout(_normalised_msg(type_or_name)).known.issuperset(fields):
                raise  # not an unknown keyword: the constructor's own error
    typename = type_or_name if isinstance(type_or_name, str) else type_name(type_or_name)
    layout = _layout(_normalised_msg(typename))
    if fields and not layout.known.issuperset(fields):
        unknown = sorted(set(fields) - layout.known)
        raise MessageError(
            f"{layout.cls.__msgtype__} has no field {unknown[0]!r}; its fields are "  # type: ignore[attr-defined]
            f"{sorted(layout.known)}"
        )
    if layout.generated and isinstance(type_or_name, str):
        _CONSTRUCTORS[type_or_name] = layout.construct
    return layout.construct(**fields)


def point(x: float, y: float, z: float) -> Any:
    """A geometry_msgs/Point at ``(x, y, z)`` [m], each coordinate a Python float."""
    return new("geometry_msgs/msg/Point", x=float(x), y=float(y), z=float(z))


def _check_base(path: str, base: str, bound: int, value: Any) -> None:
    if base in ("string", "wstring"):
        if not isinstance(value, str):
            raise MessageError(f"{path}: expected a string, got {type(value).__name__}")
        if bound and len(value) > bound:
            raise MessageError(f"{path}: string longer than its bound {bound}")
        return
    if base == "bool":
        if not isinstance(value, bool | np.bool_):
            raise MessageError(f"{path}: expected a bool, got {type(value).__name__}")
        return
    if base in ("float32", "float64"):
        if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
            raise MessageError(f"{path}: expected a number, got {type(value).__name__}")
        if base == "float32" and math.isfinite(value) and abs(float(value)) > 3.4028235e38:
            raise MessageError(f"{path}: {value} does not fit in float32")
        return
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise MessageError(f"{path}: expected an integer ({base}), got {type(value).__name__}")
    lo, hi = _INT_RANGES[base]
    if not lo <= int(value) <= hi:
        raise MessageError(f"{path}: {value} is outside the {base} range [{lo}, {hi}]")


def _check(path: str, node: tuple[Any, Any], value: Any) -> None:
    kind, arg = node
    if kind == Nodetype.BASE:
        _check_base(path, arg[0], arg[1], value)
        return
    if kind == Nodetype.NAME:
        validate(value, arg, path)
        return
    sub, length = arg
    if not isinstance(value, list | np.ndarray):
        raise MessageError(f"{path}: expected an array, got {type(value).__name__}")
    if kind == Nodetype.ARRAY and len(value) != length:
        raise MessageError(f"{path}: expected {length} elements, got {len(value)}")
    if kind == Nodetype.SEQUENCE and length and len(value) > length:
        raise MessageError(f"{path}: {len(value)} elements exceed the bound {length}")
    if isinstance(value, np.ndarray):
        if sub[0] != Nodetype.BASE or sub[1][0] not in NUMPY_DTYPES:
            raise MessageError(f"{path}: numpy array given for an array of {sub[1]}")
        want = np.dtype(NUMPY_DTYPES[sub[1][0]])
        if value.dtype != want or value.ndim != 1:
            raise MessageError(
                f"{path}: expected a 1-D {want} array, got {value.ndim}-D {value.dtype}"
            )
        return
    for i, item in enumerate(value):
        _check(f"{path}[{i}]", sub, item)


def validate(msg: Any, typename: str | None = None, path: str | None = None) -> None:
    """Check every field of ``msg`` against its type; MessageError names the bad field."""
    expected = typename or type_name(msg)
    actual = getattr(msg, "__msgtype__", None)
    where = path or expected
    if actual != expected:
        raise MessageError(f"{where}: expected a {expected} message, got {actual or type(msg)}")
    _layout(expected).check(msg, where)


def serialize(msg: Any, typename: str | None = None, *, check: bool = True) -> bytes:
    """CDR (XCDR1, little endian) bytes of ``msg``, after validating it (``check``; a
    message validated when it was published need not be again: a recorder's tap)."""
    name = typename or type_name(msg)
    if check:
        validate(msg, name)
    try:
        return bytes(typestore().serialize_cdr(msg, name))
    except Exception as exc:
        raise MessageError(f"cannot serialize {name}: {exc}") from None


def _fixed_size(node: tuple[Any, Any]) -> bool:
    kind, arg = node
    if kind == Nodetype.BASE:
        return arg[0] not in ("string", "wstring")
    if kind == Nodetype.NAME:
        return all(_fixed_size(n) for _, n in _fielddefs(arg)[1])
    return kind == Nodetype.ARRAY and _fixed_size(arg[0])


@functools.cache
def fixed_cdr_size(typename: str) -> int | None:
    """The CDR size of every ``typename`` message, or None when it varies (strings,
    sequences)."""
    if not _fixed_size((Nodetype.NAME, typename)):
        return None
    return len(serialize(new(typename), typename))


def cdr_size(msg: Any, typename: str | None = None) -> int:
    """Bytes ``msg`` takes in CDR (encapsulation header included); serializes only types
    whose size varies."""
    name = typename or type_name(msg)
    size = fixed_cdr_size(name)
    return size if size is not None else len(serialize(msg, name))


def deserialize(data: bytes | bytearray | memoryview, typename: str) -> Any:
    """Decode CDR bytes into a ``typename`` message; MessageError if they are malformed."""
    name = _normalise(typename, "msg")
    _fielddefs(name)
    try:
        return typestore().deserialize_cdr(bytes(data), name)
    except Exception as exc:
        raise MessageError(f"malformed {name} payload ({len(data)} bytes): {exc}") from None


def messages_equal(a: Any, b: Any) -> bool:
    """True when two messages have the same type and the same CDR bytes."""
    return type_name(a) == type_name(b) and serialize(a) == serialize(b)


def _type_text(node: Any) -> str:
    """A field's type as a .msg file writes it: ``float32[3]``, ``string<=8``, ``pkg/msg/T[]``."""
    kind, detail = node
    if kind == Nodetype.BASE:
        name, bound = detail
        return f"{name}<={bound}" if bound else str(name)
    if kind == Nodetype.NAME:
        return str(detail)
    inner, size = detail
    if kind == Nodetype.ARRAY:
        return f"{_type_text(inner)}[{size}]"
    return f"{_type_text(inner)}[<={size}]" if size else f"{_type_text(inner)}[]"


@dataclass(frozen=True)
class FieldInfo:
    """One field of a message type: its name, its type as .msg writes it, its default."""

    name: str
    type: str
    default: Any
    nested: bool  # a message (or array of messages), not a base type


@dataclass(frozen=True)
class ConstantInfo:
    name: str
    type: str
    value: Any


def describe(type_or_name: type | str) -> tuple[list[ConstantInfo], list[FieldInfo]]:
    """The constants and fields (type and default) of a message type."""
    msg = new(type_or_name)
    consts, fields = _fielddefs(type_name(msg))
    constants = [ConstantInfo(name, str(ctype), value) for name, ctype, value in consts]
    infos = []
    for fname, node in fields:
        nested = node[0] == Nodetype.NAME or (
            node[0] != Nodetype.BASE and node[1][0][0] == Nodetype.NAME)
        default = getattr(msg, fname)
        if isinstance(default, np.ndarray):
            default = default.tolist()
        infos.append(FieldInfo(fname, _type_text(node), default, nested))
    return constants, infos


#: The message types a service and an action are made of, in their file's order.
SERVICE_PARTS = ("request", "response")
ACTION_PARTS = ("goal", "result", "feedback")


def interface_parts(name: str) -> list[tuple[str, str]]:
    """The message types that make up the message, service or action ``name``, each with
    its part: ``[("message", T)]``, ``[("request", T_Request), ("response", T_Response)]``
    or ``[("goal", T_Goal), ("result", T_Result), ("feedback", T_Feedback)]``.

    ``pkg/msg/Name``, ``pkg/srv/Name`` and ``pkg/action/Name`` are taken as written;
    ``pkg/Name`` is looked up as a message, then a service, then an action.
    """
    parts = name.strip("/").split("/")
    if len(parts) == 3 and parts[1] in ("msg", "srv", "action"):
        kinds = [parts[1]]
    else:
        kinds = ["msg", "srv", "action"] if len(parts) == 2 else []
    types = typestore().types
    for kind in kinds:
        typename = _normalise(name, kind)
        if kind == "msg":
            if typename in types:
                return [("message", typename)]
            continue
        members = [(part, f"{typename}_{part.capitalize()}")
                   for part in (SERVICE_PARTS if kind == "srv" else ACTION_PARTS)]
        if all(member in types for _, member in members):
            return members
    what = {"msg": "message", "srv": "service", "action": "action"}
    kind_text = what[kinds[0]] if len(kinds) == 1 else "message, service or action"
    raise UnknownTypeError(f"unknown {kind_text} type {name!r}")


def registered_types(package: str | None = None) -> list[str]:
    """Every registered message type name, optionally of one package, sorted."""
    names = sorted(typestore().types)
    if package is None:
        return names
    return [n for n in names if n.startswith(f"{package}/")]
