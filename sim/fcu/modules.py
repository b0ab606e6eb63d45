"""Firmware modules declared as data (seed 002, section 3.2 and Figure 3).

A module has a name, a task group, dependencies, provided functionalities, conflicts,
and init, periodic and event functions named by string; the scheduler binds names to
callables. ``depends`` uses the seed's syntax: ``module``, ``@functionality`` and
``a|b|@c`` alternatives. Modules load from plain dicts or YAML::

    modules:
      - name: ins_ekf
        group: estimation
        depends: [imu_driver, "@gps|gps_sim"]   # or "imu_driver,@gps|gps_sim"
        provides: [ins]
        periodics:
          - {fun: ins_ekf_periodic, freq_hz: 250}   # or period_s; delay in [0, 1)
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from enum import Enum
from pathlib import Path
from typing import Any

import yaml

from runtime.parameters import load_yaml, yaml_syntax_problem
from sim.fcu.errors import ModuleSpecError


class TaskGroup(Enum):
    """Task groups; definition order is the fixed init and main-loop order.

    Paparazzi's generator uses ``mcu, core, sensors, estimation, radio_control, control,
    actuators, datalink, default`` for both init and periodic calls; ``telemetry`` is
    ours (Paparazzi sends telemetry from the main loop outside the modules) and runs
    after the datalink. ``default`` holds everything else (payload).
    """

    MCU = "mcu"
    CORE = "core"
    SENSORS = "sensors"
    ESTIMATION = "estimation"
    RADIO_CONTROL = "radio_control"
    CONTROL = "control"
    ACTUATORS = "actuators"
    DATALINK = "datalink"
    TELEMETRY = "telemetry"
    DEFAULT = "default"

    @property
    def rank(self) -> int:
        """Position in the fixed order (0 runs first)."""
        return TASK_GROUP_ORDER.index(self)


TASK_GROUP_ORDER: tuple[TaskGroup, ...] = tuple(TaskGroup)

_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*\Z")


@dataclass(frozen=True)
class ModuleRef:
    """A dependency or conflict on a module by name."""

    name: str

    def __str__(self) -> str:
        return self.name


@dataclass(frozen=True)
class FunctionalityRef:
    """A dependency or conflict on a functionality (``@name``)."""

    name: str

    def __str__(self) -> str:
        return f"@{self.name}"


@dataclass(frozen=True)
class AnyOf:
    """A logical-or dependency (``a|@b``): satisfied by its first satisfied option."""

    options: tuple[ModuleRef | FunctionalityRef, ...]

    def __str__(self) -> str:
        return "|".join(str(o) for o in self.options)


Requirement = ModuleRef | FunctionalityRef | AnyOf


def _check_name(key: str, name: object, what: str) -> str:
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise ModuleSpecError(
            key, f"{name!r} is not a valid {what} name (letters, digits, '_', '.', '-')"
        )
    return name


def _parse_ref(key: str, text: str) -> ModuleRef | FunctionalityRef:
    text = text.strip()
    if text.startswith("@"):
        return FunctionalityRef(_check_name(key, text[1:], "functionality"))
    return ModuleRef(_check_name(key, text, "module"))


def parse_requirement(text: str, key: str = "depends") -> Requirement:
    """Parse one ``depends`` entry: ``module``, ``@functionality`` or ``a|b|@c``."""
    if not isinstance(text, str):
        raise ModuleSpecError(key, f"expected a string, got {type(text).__name__}")
    parts = text.split("|")
    if len(parts) == 1:
        return _parse_ref(key, parts[0])
    return AnyOf(tuple(_parse_ref(key, p) for p in parts))


def parse_conflict(text: str, key: str = "conflicts") -> ModuleRef | FunctionalityRef:
    """Parse one ``conflicts`` entry: ``module`` or ``@functionality`` (no ``|``)."""
    if not isinstance(text, str):
        raise ModuleSpecError(key, f"expected a string, got {type(text).__name__}")
    if "|" in text:
        raise ModuleSpecError(key, f"{text!r}: '|' is only allowed in depends")
    return _parse_ref(key, text)


@dataclass(frozen=True)
class InitSpec:
    """An init function, called once in task-group then module order."""

    fun: str

    def __post_init__(self) -> None:
        _check_name("fun", self.fun, "function")


@dataclass(frozen=True)
class EventSpec:
    """An event function, called on the next event poll after its flag is set."""

    fun: str

    def __post_init__(self) -> None:
        _check_name("fun", self.fun, "function")


@dataclass(frozen=True)
class PeriodicSpec:
    """A periodic function with its rate.

    Give exactly one of ``freq_hz`` (Hz, > 0) or ``period_s`` (s, > 0). ``delay`` in
    [0, 1) pins the phase to ``floor(delay * prescaler)`` ticks (the seed's "user-specific
    instructions"); ``None`` leaves it to the offset strategy. ``autorun=False`` declares
    it stopped until started. ``cost`` (dimensionless, >= 0, default 1 = one typical
    call) weights the load the balanced offset strategy spreads.
    """

    fun: str
    freq_hz: float | None = None
    period_s: float | None = None
    delay: float | None = None
    autorun: bool = True
    cost: float = 1.0

    def __post_init__(self) -> None:
        _check_name("fun", self.fun, "function")
        if (self.freq_hz is None) == (self.period_s is None):
            raise ModuleSpecError(
                "freq_hz", f"periodic {self.fun!r}: give exactly one of freq_hz or period_s"
            )
        for key, value in (("freq_hz", self.freq_hz), ("period_s", self.period_s)):
            if value is not None and not (_is_real(value) and math.isfinite(value) and value > 0):
                raise ModuleSpecError(key, f"periodic {self.fun!r}: {value!r} must be > 0")
        if self.delay is not None and not (_is_real(self.delay) and 0.0 <= self.delay < 1.0):
            raise ModuleSpecError("delay", f"periodic {self.fun!r}: {self.delay!r} outside [0, 1)")
        if not isinstance(self.autorun, bool):
            raise ModuleSpecError("autorun", f"periodic {self.fun!r}: expected true or false")
        if not (_is_real(self.cost) and math.isfinite(self.cost) and self.cost >= 0):
            raise ModuleSpecError("cost", f"periodic {self.fun!r}: {self.cost!r} must be >= 0")

    @property
    def rate_hz(self) -> float:
        """Requested frequency in Hz, whichever way it was declared."""
        if self.freq_hz is not None:
            return float(self.freq_hz)
        assert self.period_s is not None  # __post_init__ guarantees one of the two
        return 1.0 / float(self.period_s)


def _is_real(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


@dataclass(frozen=True)
class ModuleSpec:
    """One firmware module. ``depends``/``provides``/``conflicts`` use the seed's syntax."""

    name: str
    group: TaskGroup = TaskGroup.DEFAULT
    depends: tuple[str, ...] = ()
    provides: tuple[str, ...] = ()
    conflicts: tuple[str, ...] = ()
    inits: tuple[InitSpec, ...] = ()
    periodics: tuple[PeriodicSpec, ...] = ()
    events: tuple[EventSpec, ...] = ()

    def __post_init__(self) -> None:
        _check_name("name", self.name, "module")
        where = f"module {self.name!r}"
        if not isinstance(self.group, TaskGroup):
            raise ModuleSpecError(f"{where}.group", f"expected a TaskGroup, got {self.group!r}")
        for attr in ("depends", "provides", "conflicts", "inits", "periodics", "events"):
            value = getattr(self, attr)
            if isinstance(value, str | bytes) or not isinstance(value, Sequence):
                raise ModuleSpecError(f"{where}.{attr}", "expected a sequence")
            object.__setattr__(self, attr, tuple(value))
        for i, dep in enumerate(self.depends):
            parse_requirement(dep, f"{where}.depends[{i}]")
        for i, conflict in enumerate(self.conflicts):
            parse_conflict(conflict, f"{where}.conflicts[{i}]")
        for i, provided in enumerate(self.provides):
            _check_name(f"{where}.provides[{i}]", _strip_at(provided), "functionality")
        for attr, kind in (("inits", InitSpec), ("periodics", PeriodicSpec), ("events", EventSpec)):
            seen: set[str] = set()
            for i, spec in enumerate(getattr(self, attr)):
                if not isinstance(spec, kind):
                    raise ModuleSpecError(f"{where}.{attr}[{i}]", f"expected a {kind.__name__}")
                if spec.fun in seen:
                    raise ModuleSpecError(
                        f"{where}.{attr}[{i}]", f"duplicate function {spec.fun!r}"
                    )
                seen.add(spec.fun)

    def requirements(self) -> tuple[Requirement, ...]:
        """``depends`` parsed, in declaration order."""
        return tuple(parse_requirement(d) for d in self.depends)

    def conflict_refs(self) -> tuple[ModuleRef | FunctionalityRef, ...]:
        """``conflicts`` parsed, in declaration order."""
        return tuple(parse_conflict(c) for c in self.conflicts)

    def functionalities(self) -> tuple[str, ...]:
        """Provided functionality names, without the ``@``."""
        return tuple(_strip_at(p) for p in self.provides)


def _strip_at(name: str) -> str:
    return name[1:] if isinstance(name, str) and name.startswith("@") else name


# ---------------------------------------------------------------------------------------
# Loading from dicts and YAML


def _names(value: object, key: str) -> tuple[str, ...]:
    """A list of names, or the seed's comma-separated string form."""
    if isinstance(value, str):
        return tuple(part.strip() for part in value.split(",") if part.strip())
    if isinstance(value, list | tuple) and all(isinstance(v, str) for v in value):
        return tuple(value)
    raise ModuleSpecError(key, "expected a list of names or a comma-separated string")


def _fields_from(data: object, key: str, cls: type, shorthand: str | None) -> dict[str, Any]:
    if shorthand is not None and isinstance(data, str):
        return {shorthand: data}
    if not isinstance(data, Mapping):
        raise ModuleSpecError(key, f"expected a mapping, got {type(data).__name__}")
    allowed = [f.name for f in fields(cls)]
    for k in data:
        if k not in allowed:
            raise ModuleSpecError(f"{key}.{k}", f"unknown key; allowed: {', '.join(allowed)}")
    return dict(data)


def _build(cls: type, data: object, key: str, shorthand: str | None = None) -> Any:
    kwargs = _fields_from(data, key, cls, shorthand)
    try:
        return cls(**kwargs)
    except ModuleSpecError as exc:
        raise ModuleSpecError(f"{key}.{exc.key}", exc.message) from None
    except TypeError as exc:  # missing required key
        raise ModuleSpecError(key, str(exc)) from None


def module_from_dict(data: Mapping[str, Any], key: str = "module") -> ModuleSpec:
    """Build a ModuleSpec from a plain mapping; errors name the bad key (``key`` prefix)."""
    kwargs = _fields_from(data, key, ModuleSpec, None)
    if "name" not in kwargs:
        raise ModuleSpecError(f"{key}.name", "missing required key")
    name = _check_name(f"{key}.name", kwargs["name"], "module")
    if "group" in kwargs:
        try:
            kwargs["group"] = TaskGroup(kwargs["group"])
        except ValueError:
            allowed = ", ".join(g.value for g in TaskGroup)
            raise ModuleSpecError(
                f"{key}.group", f"{kwargs['group']!r} is not a task group; allowed: {allowed}"
            ) from None
    for attr in ("depends", "provides", "conflicts"):
        if attr in kwargs:
            kwargs[attr] = _names(kwargs[attr], f"{key}.{attr}")
    for attr, cls in (("inits", InitSpec), ("periodics", PeriodicSpec), ("events", EventSpec)):
        if attr in kwargs:
            items = kwargs[attr]
            if not isinstance(items, list | tuple):
                raise ModuleSpecError(f"{key}.{attr}", "expected a list")
            shorthand = None if cls is PeriodicSpec else "fun"
            kwargs[attr] = tuple(
                _build(cls, item, f"{key}.{attr}[{i}]", shorthand) for i, item in enumerate(items)
            )
    try:
        return ModuleSpec(**kwargs)
    except ModuleSpecError as exc:
        # ModuleSpec names keys as "module 'x'.attr[i]"; rebase them on the caller's key
        prefix = f"module {name!r}"
        sub = exc.key[len(prefix) :] if exc.key.startswith(prefix) else f".{exc.key}"
        raise ModuleSpecError(f"{key}{sub}", exc.message) from None


def modules_from_yaml(text: str) -> tuple[ModuleSpec, ...]:
    """Modules from YAML text with a top-level ``modules:`` list."""
    try:
        data = load_yaml(text)
    except yaml.YAMLError as exc:
        raise ModuleSpecError("<yaml>", yaml_syntax_problem(exc)) from None
    if not isinstance(data, Mapping) or "modules" not in data:
        raise ModuleSpecError("modules", "expected a mapping with a top-level 'modules' list")
    extra = [k for k in data if k != "modules"]
    if extra:
        raise ModuleSpecError(str(extra[0]), "unknown top-level key; allowed: modules")
    items = data["modules"]
    if not isinstance(items, list):
        raise ModuleSpecError("modules", "expected a list")
    return tuple(module_from_dict(item, f"modules[{i}]") for i, item in enumerate(items))


def load_modules(path: Path) -> tuple[ModuleSpec, ...]:
    """Modules from a YAML file (see :func:`modules_from_yaml`)."""
    return modules_from_yaml(Path(path).read_text(encoding="utf-8"))
