"""Faults drawn from a run's seed: a campaign block's ``draw_faults``, validated, and the
explicit faults it gives each run (pure: the standard library and :mod:`sim.fault_spec`).

::

    draw_faults:
      count: 1-2               # faults a run: N, or FIRST-LAST
      window_s: [3, 450]       # s: each fault starts and ends inside it
      gap_s: 30                # s from one fault's end to the next one's start (default 30)
      kinds:                   # the kinds a fault is drawn from
        vio_stop: {duration_s: [1, 5]}
        packet_burst: {duration_s: [0.5, 3], loss: [0.2, 0.5]}
        node_stop: {duration_s: [2, 6], name: [navigator, mapping], weight: 2}

Under a kind: ``weight`` (how likely it is against the others; default 1), ``duration_s``
(``[LO, HI]`` or one number; the kind must take one; without it, a kind whose duration is
optional lasts to the end of the run) and the kind's own keys
(:data:`sim.fault_spec.KINDS`): a number key a ``[LO, HI]`` range or one number, inside
the key's own range; a name key (``node_stop``'s ``name``) a list of names, one drawn. A
key the kind requires must be given.

The draw (:meth:`FaultDraw.draw`) takes a :class:`random.Random` that the caller seeds from
the run (:func:`run_rng`: its seed and its block), so the same file always gives the same
runs; it returns
plain :class:`~sim.fault_spec.Fault` values, whose specs replay the run exactly. The faults
of one run never overlap: a count is drawn, then the kinds and durations, then where the
faults sit in the window, ``gap_s`` apart (the window's slack shared out by sorted uniform
offsets, so each fault's start spans the whole window). Times and durations are on a 0.1 s
grid, a number key's value on a power-of-ten grid of a hundredth to a thousandth of its
range, so the specs read short.
"""

from __future__ import annotations

import hashlib
import json
import math
import random
import re
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

from quadmission.errors import CampaignError
from sim.fault_spec import KINDS, Duration, Fault, FaultKind, FaultSpecError, Key

__all__ = ["DEFAULT_GAP_S", "DRAW_KEYS", "TIME_STEP_S", "DrawnKind", "FaultDraw",
           "parse_draw", "run_rng"]

DRAW_KEYS = frozenset({"count", "window_s", "gap_s", "kinds"})
DEFAULT_GAP_S = 30.0
"""s between one drawn fault's end and the next one's start: the first fault's reaction
(a HOLD, the settle, a RESUME: under 10 s in the faults campaign) is over before the next
fault starts, so each is judged on its own window."""
TIME_STEP_S = 0.1  # s: drawn times and durations are multiples of it
_TICKS = round(1 / TIME_STEP_S)  # grid points a second


@dataclass(frozen=True)
class Span:
    """A closed range ``[lo, hi]`` a value is drawn from (``lo == hi``: that value)."""

    lo: float
    hi: float


@dataclass(frozen=True)
class DrawnKind:
    """One kind of a draw: its duration's range (None: no duration) and its keys'."""

    kind: FaultKind
    duration_s: Span | None
    numbers: tuple[tuple[str, Span], ...] = ()
    names: tuple[tuple[str, tuple[str, ...]], ...] = ()
    weight: float = 1.0

    @property
    def longest_s(self) -> float:
        """The longest fault it draws [s] (0 for one without a duration)."""
        return 0.0 if self.duration_s is None else self.duration_s.hi


@dataclass(frozen=True)
class FaultDraw:
    """A validated ``draw_faults``: how many faults a run, where in time, of which kinds."""

    count_lo: int
    count_hi: int
    window_lo_s: float
    window_hi_s: float
    gap_s: float
    kinds: tuple[DrawnKind, ...]

    def draw(self, rng: random.Random) -> tuple[Fault, ...]:
        """One run's faults, in time order (only ``rng.random()`` is used: the same seed
        gives the same faults on every Python)."""
        count = self.count_lo + _below(rng, self.count_hi - self.count_lo + 1)
        picked = [self._pick(rng) for _ in range(count)]
        durations = [None if k.duration_s is None else _on_grid(rng, k.duration_s)
                     for k in picked]
        lengths = [0 if d is None else d for d in durations]
        start, end, gap = self._grid()
        slack = end - start - sum(lengths) - gap * (count - 1)
        assert slack >= 0, "parse_draw checks that the longest faults fit the window"
        offsets = sorted(_below(rng, slack + 1) for _ in range(count))
        faults, used = [], 0
        for kind, duration, length, offset in zip(picked, durations, lengths, offsets,
                                                  strict=True):
            at = start + offset + used
            used += length + gap
            values: dict[str, float | str] = {
                key: _number(rng, span) for key, span in kind.numbers}
            values |= {key: names[_below(rng, len(names))] for key, names in kind.names}
            faults.append(Fault.of(kind.kind, at / _TICKS,
                                   None if duration is None else duration / _TICKS, **values))
        return tuple(faults)

    def _pick(self, rng: random.Random) -> DrawnKind:
        """A kind, as likely as its weight against the others'."""
        u = rng.random() * sum(k.weight for k in self.kinds)
        for kind in self.kinds:
            u -= kind.weight
            if u < 0:
                return kind
        return self.kinds[-1]

    def _grid(self) -> tuple[int, int, int]:
        """The window's start and end and the gap, in grid steps (inside the window, at
        least the gap)."""
        return (_ticks_up(self.window_lo_s), _ticks_down(self.window_hi_s),
                _ticks_up(self.gap_s))

    @property
    def needs_s(self) -> float:
        """The time the most faults, each of the longest, take with their gaps [s]."""
        longest = max(_ticks_down(k.longest_s) for k in self.kinds)
        return (self.count_hi * longest + (self.count_hi - 1) * self._grid()[2]) / _TICKS


def _ticks_up(seconds: float) -> int:
    return math.ceil(seconds * _TICKS - 1e-9)


def _ticks_down(seconds: float) -> int:
    return math.floor(seconds * _TICKS + 1e-9)


def run_rng(*parts: Any) -> random.Random:
    """A generator seeded from ``parts`` (a run's seed and what makes its block), the same
    on every machine and Python (a SHA-256 of their JSON, not ``hash()``)."""
    text = json.dumps(parts, sort_keys=True, default=str)
    return random.Random(int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "big"))


def _below(rng: random.Random, n: int) -> int:
    """An integer in ``[0, n)``, each as likely."""
    return min(int(rng.random() * n), n - 1)


def _on_grid(rng: random.Random, span: Span) -> int:
    """A duration in ``span`` as a number of grid steps (at least one)."""
    lo, hi = _ticks_up(span.lo), _ticks_down(span.hi)
    return lo + _below(rng, hi - lo + 1)


def _number(rng: random.Random, span: Span) -> float:
    """A key's value in ``span``, on a power-of-ten grid a hundredth to a thousandth of
    its width (so a spec reads ``loss=0.367``, not 17 digits)."""
    if span.hi == span.lo:
        return span.lo
    step = 10.0 ** (math.floor(math.log10(span.hi - span.lo)) - 2)
    value = round((span.lo + rng.random() * (span.hi - span.lo)) / step) * step
    return min(max(float(f"{value:.12g}"), span.lo), span.hi)


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) \
        and math.isfinite(value)


def _span(value: Any, where: str, *, lo: float, hi: float, unit: str) -> Span:
    """``[LO, HI]`` or one number, inside ``[lo, hi]``."""
    pair = list(value) if isinstance(value, list | tuple) else [value, value]
    if len(pair) != 2 or not all(_is_number(v) for v in pair):
        raise CampaignError(f"{where}: {value!r} is not [LO, HI] or a number")
    a, b = float(pair[0]), float(pair[1])
    if b < a:
        raise CampaignError(f"{where}: {value!r} ends before it starts")
    if not (lo <= a and b <= hi):
        raise CampaignError(f"{where}: {value!r} is outside the key's range "
                            f"[{lo:g}, {hi:g}] {unit}".rstrip())
    return Span(a, b)


def _count(value: Any, where: str) -> tuple[int, int]:
    if isinstance(value, str):
        match = re.fullmatch(r"\s*(\d+)\s*-\s*(\d+)\s*", value)
        if match is None:
            raise CampaignError(f"{where}: {value!r} is not N or FIRST-LAST (e.g. 1-2)")
        lo, hi = int(match[1]), int(match[2])
    elif isinstance(value, int) and not isinstance(value, bool):
        lo = hi = value
    else:
        raise CampaignError(f"{where}: {value!r} is not N or FIRST-LAST (e.g. 1-2)")
    if lo < 1 or hi < lo:
        raise CampaignError(f"{where}: {value!r}: at least 1 fault, FIRST <= LAST")
    return lo, hi


def _kind(name: Any, entry: Any, where: str,
          node_names: Collection[str] | None) -> DrawnKind:
    try:
        kind = FaultKind(name)
    except ValueError:
        raise CampaignError(f"{where}: unknown fault kind {name!r} (known: "
                            f"{', '.join(k.value for k in FaultKind)})") from None
    spec = KINDS[kind]
    keys: dict[str, Key] = {k.name: k for k in spec.keys}
    allowed = ", ".join(sorted({"weight", "duration_s", *keys}))
    entry = {} if entry is None else entry
    if not isinstance(entry, Mapping):
        raise CampaignError(f"{where}: expected a mapping with keys {allowed}, got {entry!r}")
    unknown = sorted(set(entry) - {"weight", "duration_s", *keys})
    if unknown:
        raise CampaignError(f"{where}: unknown key {unknown[0]!r} for {kind.value} (allowed: "
                            f"{allowed})")
    duration = None
    if "duration_s" in entry:
        if spec.duration is Duration.NONE:
            raise CampaignError(f"{where}.duration_s: {kind.value} takes no duration")
        duration = _span(entry["duration_s"], f"{where}.duration_s", lo=0.0, hi=math.inf,
                         unit="s")
        if _ticks_up(duration.lo) > _ticks_down(duration.hi) or duration.hi < TIME_STEP_S:
            raise CampaignError(f"{where}.duration_s: {entry['duration_s']!r} holds no "
                                f"multiple of {TIME_STEP_S:g} s (durations are drawn on "
                                "that grid)")
    elif spec.duration is Duration.REQUIRED:
        raise CampaignError(f"{where}: {kind.value} needs duration_s: [LO, HI]")
    numbers, names = [], []
    for key in spec.keys:
        if key.name not in entry:
            if key.required:
                raise CampaignError(f"{where}: {kind.value} needs {key.name}")
            continue
        at = f"{where}.{key.name}"
        if not key.text:
            numbers.append((key.name, _span(entry[key.name], at, lo=key.lo, hi=key.hi,
                                            unit=key.unit)))
            continue
        given = entry[key.name]
        listed = list(given) if isinstance(given, list | tuple) else [given]
        if not listed or not all(isinstance(n, str) and n.strip() for n in listed):
            raise CampaignError(f"{at}: {given!r} is not a list of names")
        if node_names is not None and kind is FaultKind.NODE_STOP:
            bad = [n for n in listed if n not in node_names]
            if bad:
                raise CampaignError(f"{at}: no node {bad[0]!r} with an expected reaction "
                                    f"(nodes: {', '.join(sorted(node_names))})")
        names.append((key.name, tuple(listed)))
    weight = entry.get("weight", 1.0)
    if not _is_number(weight) or not weight > 0:
        raise CampaignError(f"{where}.weight: {weight!r} is not a number > 0")
    drawn = DrawnKind(kind, duration, tuple(numbers), tuple(names), float(weight))
    try:  # the kind's own checks, on the extremes of each range
        for pick in (min, max):
            Fault.of(kind, 0.0, None if duration is None else pick(duration.lo, duration.hi),
                     **{k: pick(s.lo, s.hi) for k, s in numbers},
                     **{k: n[0] for k, n in names})
    except FaultSpecError as exc:
        raise CampaignError(f"{where}: {exc}") from None
    return drawn


def parse_draw(data: Any, where: str, *,
               node_names: Collection[str] | None = None) -> FaultDraw:
    """A block's ``draw_faults``; every error names ``where``, the key and the value.
    ``node_names``: the nodes ``node_stop`` may name (None: not checked here)."""
    allowed = ", ".join(sorted(DRAW_KEYS))
    if not isinstance(data, Mapping):
        raise CampaignError(f"{where}: expected a mapping with keys {allowed}, got {data!r}")
    unknown = sorted(set(data) - DRAW_KEYS)
    if unknown:
        raise CampaignError(f"{where}: unknown key {unknown[0]!r} (allowed: {allowed})")
    for required in ("count", "window_s", "kinds"):
        if required not in data:
            raise CampaignError(f"{where}: missing {required!r}")
    count_lo, count_hi = _count(data["count"], f"{where}.count")
    window = _span(data["window_s"], f"{where}.window_s", lo=0.0, hi=math.inf, unit="s")
    gap = data.get("gap_s", DEFAULT_GAP_S)
    if not _is_number(gap) or gap < 0:
        raise CampaignError(f"{where}.gap_s: {gap!r} is not a number of seconds >= 0")
    entries = data["kinds"]
    if not isinstance(entries, Mapping) or not entries:
        raise CampaignError(f"{where}.kinds: expected a mapping of fault kinds, got "
                            f"{entries!r}")
    kinds = tuple(_kind(name, entry, f"{where}.kinds.{name}", node_names)
                  for name, entry in entries.items())
    draw = FaultDraw(count_lo, count_hi, window.lo, window.hi, float(gap), kinds)
    start, end, _ = draw._grid()
    if (end - start) / _TICKS < draw.needs_s:
        raise CampaignError(f"{where}.window_s: {data['window_s']!r} is shorter than "
                            f"{count_hi} of the longest faults "
                            f"({max(k.longest_s for k in kinds):g} s), {gap:g} s apart "
                            f"({draw.needs_s:g} s)")
    return draw
