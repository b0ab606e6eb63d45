"""Fault specifications: what goes wrong, when, for how long (issue 22). Parsed once.

A fault is written ``KIND@T[:DURATION][,key=value...]`` (``T`` and ``DURATION`` in
simulated seconds from the start of the run), e.g. ``vio_stop@40:5``,
``battery_critical@30``, ``wind_gust@35:2,force=3,direction_deg=90``, or as a YAML file
holding a list of mappings with the same fields::

    - {kind: vio_stop, at_s: 40, duration_s: 5}
    - {kind: wind_gust, at_s: 35, duration_s: 2, force: 3.0, direction_deg: 90}

Each kind declares once whether it takes a duration and which keys, with their unit,
default and range (:data:`KINDS`); an error names the bad part. The faults act where they
would on a real drone: :mod:`sim.faults` in the simulator, on the link and in the FCU;
the operator's (outside the companion under test) in the app. Pure module: PyYAML only.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import yaml

from sim.arena import ROBOT_SPEED_LIMITS
from sim.errors import SimError

__all__ = ["KINDS", "Fault", "FaultKind", "FaultSpecError", "Key", "KindSpec", "load_faults",
           "parse_fault", "parse_faults"]


class FaultSpecError(SimError, ValueError):
    """A fault specification that cannot be used; the message names the bad part."""


class FaultKind(Enum):
    """What goes wrong; the value is how a spec names it."""

    VIO_STOP = "vio_stop"  # the visual odometry stops publishing
    LINK_LOST = "link_lost"  # the FCU <-> companion serial link loses every message
    BATTERY_LOW = "battery_low"  # the pack sags below PX4's BAT_LOW_THR
    BATTERY_CRITICAL = "battery_critical"  # ... below BAT_CRIT_THR
    WIND_GUST = "wind_gust"  # a horizontal force on the quadrotor's body
    OPERATOR_ABORT = "operator_abort"  # the operator presses ABORT
    VIO_JUMP = "vio_jump"  # the visual odometry jumps by an offset (a relocalisation)
    VIO_DELAY = "vio_delay"  # the visual odometry comes late
    LATENCY_SPIKE = "latency_spike"  # every FCU link message is late
    PACKET_BURST = "packet_burst"  # a burst of lost FCU link messages
    CLOCK_JUMP = "clock_jump"  # the companion's clock (the XRCE agent's) jumps
    CAMERA_DARK = "camera_dark"  # the down camera publishes black images
    DEPTH_DARK = "depth_dark"  # the depth camera publishes empty clouds
    PAD_OCCLUDED = "pad_occluded"  # a pad's marker is gone (the pad is still there)
    LIGHT_DROP = "light_drop"  # the arena's light drops to the dark preset
    ROBOT_ABSENT = "robot_absent"  # no robot carries the target marker
    OPERATOR_SILENT = "operator_silent"  # the operator never sends a landing sequence
    NODE_STOP = "node_stop"  # a companion node stops (its process dies)
    ROBOT_ACROSS = "robot_across"  # a ground robot drives across the vehicle's path


class Duration(Enum):
    """Whether a kind takes a duration."""

    NONE = "none"  # a step: it happens once and stays
    OPTIONAL = "optional"  # without one it lasts to the end of the run
    REQUIRED = "required"


@dataclass(frozen=True)
class Key:
    """A kind's ``key=value`` with its unit, default and closed range."""

    name: str
    default: float
    unit: str
    lo: float
    hi: float
    doc: str
    required: bool = False  # the spec must give it
    text: bool = False  # a name (checked where it is used), not a number


@dataclass(frozen=True)
class KindSpec:
    duration: Duration
    keys: tuple[Key, ...]
    doc: str


KINDS: dict[FaultKind, KindSpec] = {
    FaultKind.VIO_STOP: KindSpec(Duration.OPTIONAL, (), "the visual odometry publishes "
                                 "nothing for DURATION s (to the end without one)"),
    FaultKind.LINK_LOST: KindSpec(Duration.OPTIONAL, (), "every message on the FCU link, "
                                  "both ways, is lost for DURATION s (to the end without one)"),
    FaultKind.BATTERY_LOW: KindSpec(Duration.NONE, (
        Key("remaining", math.nan, "", 0.0, 1.0, "charge left after the sag (default: half "
            "way between BAT_CRIT_THR and BAT_LOW_THR)"),), "the pack sags to LOW"),
    FaultKind.BATTERY_CRITICAL: KindSpec(Duration.NONE, (
        Key("remaining", math.nan, "", 0.0, 1.0, "charge left after the sag (default: half "
            "way between BAT_EMERGEN_THR and BAT_CRIT_THR)"),), "the pack sags to CRITICAL"),
    FaultKind.WIND_GUST: KindSpec(Duration.REQUIRED, (
        Key("force", 2.0, "N", 0.0, 50.0, "horizontal force on the body"),
        Key("direction_deg", 0.0, "deg", -360.0, 360.0,
            "where the force pushes, from map +x (east) towards +y (north)"),),
        "a gust pushes the quadrotor for DURATION s"),
    FaultKind.OPERATOR_ABORT: KindSpec(Duration.NONE, (), "the operator presses ABORT"),
    FaultKind.VIO_JUMP: KindSpec(Duration.NONE, tuple(
        Key(axis, 0.0, "m", -20.0, 20.0, f"jump along map {axis}") for axis in "xyz"),
        "the visual odometry jumps by (x, y, z) and stays offset (a relocalisation)"),
    FaultKind.VIO_DELAY: KindSpec(Duration.REQUIRED, (
        Key("delay_ms", 200.0, "ms", 0.0, 10_000.0, "extra processing delay"),),
        "the visual odometry is published delay_ms late for DURATION s"),
    FaultKind.LATENCY_SPIKE: KindSpec(Duration.REQUIRED, (
        Key("latency_ms", 300.0, "ms", 0.0, 10_000.0, "extra latency, both ways"),),
        "every FCU link message is latency_ms late for DURATION s"),
    FaultKind.PACKET_BURST: KindSpec(Duration.REQUIRED, (
        Key("loss", 0.5, "", 0.0, 1.0, "chance a message is lost, both ways"),),
        "FCU link messages are lost with probability loss for DURATION s"),
    FaultKind.CLOCK_JUMP: KindSpec(Duration.NONE, (
        Key("offset_ms", 1000.0, "ms", -1e7, 1e7, "the jump (positive: ahead)"),),
        "the companion's clock, as the XRCE agent answers the FCU's time sync, jumps"),
    FaultKind.CAMERA_DARK: KindSpec(Duration.OPTIONAL, (), "the down camera publishes "
                                    "black images for DURATION s (to the end without one)"),
    FaultKind.DEPTH_DARK: KindSpec(Duration.OPTIONAL, (), "the depth camera publishes empty "
                                   "clouds for DURATION s (to the end without one)"),
    FaultKind.PAD_OCCLUDED: KindSpec(Duration.NONE, (
        Key("pad", math.nan, "", 1.0, 1000.0, "the pad's marker id", required=True),),
        "the pad's marker is gone (covered), the pad itself still there"),
    FaultKind.LIGHT_DROP: KindSpec(Duration.NONE, (), "the light drops to the dark preset"),
    FaultKind.ROBOT_ABSENT: KindSpec(Duration.NONE, (
        Key("robot", math.nan, "", 1.0, 1000.0, "the marker to take away (default: the "
            "mission's target)"),), "no robot carries the marker any more"),
    FaultKind.OPERATOR_SILENT: KindSpec(Duration.NONE, (), "the operator answers nothing "
                                        "from then on (no landing sequence)"),
    FaultKind.NODE_STOP: KindSpec(Duration.OPTIONAL, (
        Key("name", math.nan, "", 0.0, 0.0, "the node's name", required=True, text=True),),
        "a companion node stops (in process: no longer executed; under --transport ros2: "
        "its process killed); in process, DURATION s later a fresh instance of it starts "
        "(its process restarted; under ros2 the launch file's respawn says it)"),
    FaultKind.ROBOT_ACROSS: KindSpec(Duration.NONE, (
        Key("robot", math.nan, "", 1.0, 1000.0, "the robot's marker (default: the robot "
            "nearest the crossing point)"),
        Key("ahead", 2.0, "m", 0.0, 20.0, "the crossing point: this far ahead of the "
            "vehicle along its horizontal velocity (its heading when hovering)"),
        Key("beyond", 1.0, "m", 0.0, 20.0, "how far past the crossing point it drives "
            "before it stops"),
        Key("speed", 0.5, "m/s", *ROBOT_SPEED_LIMITS, "its speed (a robot's range)"),),
        "a ground robot leaves its route and drives straight across the vehicle's path, "
        "then stops"),
}


@dataclass(frozen=True)
class Fault:
    """One fault: its kind, when it starts [s], how long it lasts [s] (None: a step, or
    to the end of the run), and its keys (every key of the kind, defaults filled in)."""

    kind: FaultKind
    at_s: float
    duration_s: float | None = None
    values: tuple[tuple[str, float], ...] = ()
    texts: tuple[tuple[str, str], ...] = ()
    """The kind's text keys (a node's name)."""

    def __post_init__(self) -> None:
        name = self.spec()
        spec = KINDS[self.kind]
        if not (math.isfinite(self.at_s) and self.at_s >= 0.0):
            raise FaultSpecError(f"fault {name!r}: time must be >= 0 s, got {self.at_s!r}")
        if self.duration_s is not None:
            if spec.duration is Duration.NONE:
                raise FaultSpecError(f"fault {name!r}: {self.kind.value} takes no duration")
            if not (math.isfinite(self.duration_s) and self.duration_s > 0.0):
                raise FaultSpecError(
                    f"fault {name!r}: duration must be > 0 s, got {self.duration_s!r}")
        elif spec.duration is Duration.REQUIRED:
            raise FaultSpecError(f"fault {name!r}: {self.kind.value} needs a duration "
                                 f"({self.kind.value}@T:DURATION)")
        known = {k.name: k for k in spec.keys}
        given = dict(self.values) | dict(self.texts)
        for key in given:
            k = known.get(key)
            if k is None:
                names = ", ".join(sorted(known)) or "none"
                raise FaultSpecError(f"fault {name!r}: unknown key {key!r} for "
                                     f"{self.kind.value} (known: {names})")
            if k.text != (key in dict(self.texts)):
                raise FaultSpecError(f"fault {name!r}: {key} must be "
                                     f"{'a name' if k.text else 'a number'}")
        for k in spec.keys:
            missing = k.name not in given or (not k.text and math.isnan(float(given[k.name])))
            if k.required and missing:
                raise FaultSpecError(f"fault {name!r}: {self.kind.value} needs {k.name}=...")
            if k.text and k.name in given and not str(given[k.name]).strip():
                raise FaultSpecError(f"fault {name!r}: {k.name} is empty")
        for key, value in self.values:
            k = known[key]
            if not (k.lo <= value <= k.hi) and not (math.isnan(value) and math.isnan(k.default)
                                                     and not k.required):
                raise FaultSpecError(f"fault {name!r}: {key}={_number(value)} is outside "
                                     f"[{_number(k.lo)}, {_number(k.hi)}] {k.unit}".rstrip())

    @classmethod
    def of(cls, kind: FaultKind, at_s: float, duration_s: float | None = None,
           **values: float | str) -> Fault:
        """A fault with the kind's defaults for the keys not given (checked)."""
        spec = KINDS[kind]
        names = sorted(k.name for k in spec.keys)
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise FaultSpecError(f"fault {kind.value}@{_number(at_s)}: unknown key "
                                 f"{unknown[0]!r} for {kind.value} "
                                 f"(known: {', '.join(names) or 'none'})")
        filled, texts = [], []
        for k in spec.keys:
            v = values.get(k.name, k.default)
            if k.text:
                if k.name in values:
                    texts.append((k.name, str(v)))
                continue
            try:
                filled.append((k.name, float(v)))
            except ValueError:
                raise FaultSpecError(f"fault {kind.value}@{_number(at_s)}: {k.name}={v!r} is "
                                     "not a number") from None
        return cls(kind, float(at_s), None if duration_s is None else float(duration_s),
                   tuple(filled), tuple(texts))

    def value(self, key: str) -> float:
        """The value of ``key`` (NaN: the kind's computed default)."""
        for name, value in self.values:
            if name == key:
                return value
        raise KeyError(f"{self.kind.value} has no key {key!r}")

    def text(self, key: str) -> str:
        """The text of ``key`` (a node's name)."""
        for name, value in self.texts:
            if name == key:
                return value
        raise KeyError(f"{self.kind.value} has no text key {key!r}")

    @property
    def end_s(self) -> float:
        """When the fault is over [s]: ``inf`` for one that lasts to the end (or a step)."""
        return math.inf if self.duration_s is None else self.at_s + self.duration_s

    def spec(self) -> str:
        """The fault written back as a spec string (replays it)."""
        out = f"{self.kind.value}@{_number(self.at_s)}"
        if self.duration_s is not None:
            out += f":{_number(self.duration_s)}"
        given = [f"{k}={_number(v)}" for k, v in self.values if not math.isnan(v)]
        given += [f"{k}={v}" for k, v in self.texts]
        return ",".join([out, *given])

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind.value, "at_s": self.at_s, "duration_s": self.duration_s,
                **{k: v for k, v in self.values if not math.isnan(v)}, **dict(self.texts)}


def _number(value: float) -> str:
    """``value`` short (``50``, ``0.5``) when that reads back as the same float, else in
    full: ``50.00000000000001`` is not written ``50``, which is in a range it is outside,
    and a spec written back replays the very value."""
    short = f"{value:g}"
    return short if float(short) == value else repr(value)


#: the head of a fault's error: ``fault 'SPEC': `` or ``fault KIND@T: ``
_ERROR_HEAD = re.compile(r"^fault (?:'[^']*'|\S+): ")


def _kind(name: str, where: str) -> FaultKind:
    try:
        return FaultKind(name.strip())
    except ValueError:
        known = ", ".join(k.value for k in FaultKind)
        raise FaultSpecError(f"fault {where!r}: unknown fault kind {name.strip()!r} "
                             f"(known: {known})") from None


def _seconds(text: str, what: str, where: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise FaultSpecError(f"fault {where!r}: {what} {text!r} is not a number of "
                             "seconds") from None


def parse_fault(text: str) -> Fault:
    """One ``KIND@T[:DURATION][,key=value...]``."""
    head, *pairs = text.strip().split(",")
    if "@" not in head:
        raise FaultSpecError(f"fault {text!r}: expected KIND@T[:DURATION][,key=value...]")
    name, when = head.split("@", 1)
    kind = _kind(name, text)
    at, _, duration = when.partition(":")
    at_s = _seconds(at, "time", text)
    duration_s = _seconds(duration, "duration", text) if duration else None
    values: dict[str, float | str] = {}
    texts = {k.name for k in KINDS[kind].keys if k.text}
    for pair in pairs:
        key, eq, raw = pair.partition("=")
        if not eq:
            raise FaultSpecError(f"fault {text!r}: {pair!r} is not key=value")
        if key.strip() in texts:
            values[key.strip()] = raw.strip()
            continue
        try:
            values[key.strip()] = float(raw)
        except ValueError:
            raise FaultSpecError(f"fault {text!r}: {key.strip()}={raw!r} is not a "
                                 "number") from None
    try:
        return Fault.of(kind, at_s, duration_s, **values)
    except FaultSpecError as exc:
        # the spec as written, not as rebuilt from its parts, names the fault
        raise FaultSpecError(_ERROR_HEAD.sub(f"fault {text!r}: ", str(exc), count=1)) from None


def parse_faults(texts: Iterable[str]) -> tuple[Fault, ...]:
    """Several specs, in the order given."""
    return tuple(parse_fault(t) for t in texts)


def _from_mapping(entry: Any, where: str) -> Fault:
    if not isinstance(entry, Mapping):
        raise FaultSpecError(f"{where}: expected a mapping {{kind, at_s, ...}}, got {entry!r}")
    fields = dict(entry)
    for required in ("kind", "at_s"):
        if required not in fields:
            raise FaultSpecError(f"{where}: missing {required!r}")
    kind = _kind(str(fields.pop("kind")), where)
    at = fields.pop("at_s")
    duration = fields.pop("duration_s", None)
    texts = {k.name for k in KINDS[kind].keys if k.text}
    try:
        values = {str(k): (str(v) if k in texts else float(v)) for k, v in fields.items()}
        at_s = float(at)
        duration_s = None if duration is None else float(duration)
    except (TypeError, ValueError):
        raise FaultSpecError(f"{where}: at_s, duration_s and the keys must be numbers, "
                             f"got {entry!r}") from None
    try:
        return Fault.of(kind, at_s, duration_s, **values)
    except FaultSpecError as exc:
        raise FaultSpecError(f"{where}: {exc}") from None


def load_faults(path: Path) -> tuple[Fault, ...]:
    """The faults of a YAML file: a list of ``{kind, at_s, duration_s?, key: value...}``."""
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise FaultSpecError(f"{path}: {exc}") from None
    if not isinstance(data, list):
        raise FaultSpecError(f"{path}: expected a list of faults, got {type(data).__name__}")
    return tuple(_from_mapping(entry, f"{path}: fault {i + 1}") for i, entry in enumerate(data))
