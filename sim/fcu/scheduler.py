"""Paparazzi-style static scheduler (seed 002, section 4): resolve once, then tick.

The three steps of the seed:

1. :func:`resolve` orders the modules (Algorithms 1-2, :mod:`sim.fcu.resolution`);
2. init, periodic and event functions are grouped by task group and called in the fixed
   :data:`~sim.fcu.modules.TASK_GROUP_ORDER`, modules in resolved order within a group;
3. each periodic function gets a prescaler (main-loop ticks per call, checked to be an
   integer) and an offset from an :class:`~sim.fcu.offsets.OffsetStrategy`.

:class:`Scheduler` runs the result one main-loop tick at a time. Simulated time comes
from an injected :class:`Clock` (deterministic in the simulator); host time
(``time.perf_counter_ns``) is only used for the duty statistics of Table 2.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any, NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

from sim.fcu.errors import BindingError, ModuleSpecError, RateError, SchedulerError
from sim.fcu.modules import TASK_GROUP_ORDER, ModuleSpec, PeriodicSpec, TaskGroup
from sim.fcu.offsets import (
    OffsetRequest,
    OffsetStrategy,
    checked_offsets,
    delay_to_offset,
    get_strategy,
    hyperperiod,
    tick_loads,
)
from sim.fcu.resolution import sort_modules

DEFAULT_MAIN_FREQ_HZ = 500
"""Main-loop frequency (Hz) of the seed's test flight (section 5)."""

DEFAULT_WINDOW_CALLS = 1000
_PHASES_CACHED = 100_000  # tick phases whose due functions are kept (the cycle is usually short)
"""Calls per duty-statistics window (seed 002, section 5: "each data point corresponds to
1000 calls")."""

_RATE_TOLERANCE = 1e-9


# ---------------------------------------------------------------------------------------
# Static schedule


@dataclass(frozen=True)
class ScheduledPeriodic:
    """A periodic function placed on the main loop: due when ``tick % prescaler == offset``."""

    module: str
    group: TaskGroup
    fun: str
    freq_hz: float
    prescaler: int
    offset: int
    autorun: bool
    cost: float
    pinned: bool
    """True if the module's ``delay`` fixed the offset."""

    def due(self, tick: int) -> bool:
        """Whether this function runs on main-loop tick ``tick`` (0-based)."""
        return tick % self.prescaler == self.offset


@dataclass(frozen=True)
class ScheduledCall:
    """An init or event function with the module and group it belongs to."""

    module: str
    group: TaskGroup
    fun: str


@dataclass(frozen=True)
class ResolvedSchedule:
    """The static schedule: module order, and every function in call order."""

    modules: tuple[ModuleSpec, ...]
    """Selected modules and their dependencies, ordered by Algorithm 1."""
    main_freq_hz: int
    strategy: str
    """Name of the offset strategy that placed the periodic functions."""
    inits: tuple[ScheduledCall, ...]
    periodics: tuple[ScheduledPeriodic, ...]
    """In call order: task group, then module order, then declaration order."""
    events: tuple[ScheduledCall, ...]

    @property
    def module_order(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.modules)

    @property
    def tick_period_ns(self) -> int:
        """Main-loop period, ns (rounded down for frequencies that do not divide 1e9)."""
        return 1_000_000_000 // self.main_freq_hz

    @property
    def hyperperiod_ticks(self) -> int:
        """Ticks after which the periodic call pattern repeats."""
        return hyperperiod(p.prescaler for p in self.periodics)

    def due(self, tick: int) -> tuple[ScheduledPeriodic, ...]:
        """Periodic functions due on ``tick``, in call order (stopped ones included)."""
        return tuple(p for p in self.periodics if p.due(tick))

    def with_offsets(self, strategy: str | OffsetStrategy) -> ResolvedSchedule:
        """The same schedule with offsets re-assigned by another strategy."""
        chosen = get_strategy(strategy)
        by_module = {m: i for i, m in enumerate(self.module_order)}
        # strategies see functions in resolved module order, as the seed's generator does
        order = sorted(
            range(len(self.periodics)), key=lambda i: by_module[self.periodics[i].module]
        )
        requests = [_request(self.periodics[i]) for i in order]
        offsets = checked_offsets(chosen, requests)
        placed = list(self.periodics)
        for i, offset in zip(order, offsets, strict=True):
            placed[i] = replace(placed[i], offset=offset)
        return replace(self, strategy=chosen.name, periodics=tuple(placed))


def _request(p: ScheduledPeriodic) -> OffsetRequest:
    return OffsetRequest(p.prescaler, p.offset if p.pinned else None, p.cost)


def prescaler_for(spec: PeriodicSpec, main_freq_hz: int, module: str = "?") -> int:
    """Main-loop ticks per call of ``spec``; RateError unless a positive integer.

    The seed's generator truncates ``MODULES_FREQUENCY * period`` silently; here a rate
    the main loop cannot realise exactly (above it, or not an integer divisor of it) is
    rejected with the numbers involved.
    """
    if spec.period_s is not None:
        ratio = Fraction(spec.period_s) * main_freq_hz
        declared = f"period {spec.period_s} s"
    else:
        assert spec.freq_hz is not None
        ratio = Fraction(main_freq_hz) / Fraction(spec.freq_hz)
        declared = f"{spec.freq_hz} Hz"
    where = f"periodic {spec.fun!r} of module {module!r} ({declared})"
    nearest = round(ratio)
    if ratio < 1 - _RATE_TOLERANCE:
        raise RateError(f"{where} is faster than the {main_freq_hz} Hz main loop")
    if abs(ratio - nearest) > _RATE_TOLERANCE * ratio:
        raise RateError(
            f"{where} needs a prescaler of {float(ratio):.4g} main-loop ticks at "
            f"{main_freq_hz} Hz; it must be an integer (nearest realisable rate: "
            f"{main_freq_hz / max(1, nearest):.6g} Hz)"
        )
    return max(1, int(nearest))


def resolve(
    modules: Iterable[ModuleSpec],
    selected: Sequence[str] | None = None,
    *,
    main_freq_hz: int = DEFAULT_MAIN_FREQ_HZ,
    offsets: str | OffsetStrategy = "balanced",
) -> ResolvedSchedule:
    """Build the static schedule of seed 002, section 4.

    Step 1: :func:`~sim.fcu.resolution.sort_modules` (Algorithm 1, with Algorithm 2
    twice) orders the ``selected`` modules (default: all) and their dependencies from
    the catalogue ``modules``. Step 2: functions are grouped by task group in the fixed
    order, modules in that order within a group. Step 3: each periodic function gets a
    prescaler (checked, see :func:`prescaler_for`) and an offset from the strategy
    ``offsets`` (a registry name or an :class:`OffsetStrategy`; a declared ``delay``
    always wins).

    Raises DependencyCycleError, ConflictError, MissingFunctionalityError, RateError, or
    ModuleSpecError for duplicate module or function names.
    """
    if isinstance(main_freq_hz, bool) or not isinstance(main_freq_hz, int) or main_freq_hz <= 0:
        raise RateError(f"main_freq_hz: {main_freq_hz!r} must be a positive integer (Hz)")
    ordered = sort_modules(modules, selected)
    strategy = get_strategy(offsets)
    by_group = sorted(ordered, key=lambda m: m.group.rank)  # stable: module order kept

    inits = tuple(ScheduledCall(m.name, m.group, s.fun) for m in by_group for s in m.inits)
    events = tuple(ScheduledCall(m.name, m.group, s.fun) for m in by_group for s in m.events)
    _check_unique("inits", (c.fun for c in inits))
    _check_unique("events", (c.fun for c in events))

    # offsets are assigned in resolved module order (the naive counter depends on it)
    unplaced: list[ScheduledPeriodic] = []
    for module in ordered:
        for spec in module.periodics:
            prescaler = prescaler_for(spec, main_freq_hz, module.name)
            pinned = spec.delay is not None
            unplaced.append(
                ScheduledPeriodic(
                    module=module.name,
                    group=module.group,
                    fun=spec.fun,
                    freq_hz=main_freq_hz / prescaler,
                    prescaler=prescaler,
                    offset=delay_to_offset(spec.delay, prescaler) if spec.delay is not None else 0,
                    autorun=spec.autorun,
                    cost=spec.cost,
                    pinned=pinned,
                )
            )
    _check_unique("periodics", (p.fun for p in unplaced))
    placed_offsets = checked_offsets(strategy, [_request(p) for p in unplaced])
    placed = [replace(p, offset=o) for p, o in zip(unplaced, placed_offsets, strict=True)]
    rank = {name: i for i, name in enumerate(m.name for m in ordered)}
    periodics = tuple(sorted(placed, key=lambda p: (p.group.rank, rank[p.module])))
    return ResolvedSchedule(ordered, main_freq_hz, strategy.name, inits, periodics, events)


def _check_unique(kind: str, names: Iterable[str]) -> None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise ModuleSpecError(kind, f"function {name!r} is declared by two modules")
        seen.add(name)


# ---------------------------------------------------------------------------------------
# Call pattern


@dataclass(frozen=True)
class CallPattern:
    """Which periodic functions run on which tick over one hyperperiod."""

    strategy: str
    hyperperiod_ticks: int
    ticks: tuple[tuple[str, ...], ...]
    """Function names due on each tick, in call order."""
    peak: int
    """Most functions on one tick."""
    mean: float
    """Functions per tick on average (independent of the offsets: sum of 1/prescaler)."""
    peak_cost: float
    """Largest summed ``cost`` on one tick."""
    mean_cost: float

    @property
    def counts(self) -> tuple[int, ...]:
        return tuple(len(t) for t in self.ticks)


def call_pattern(schedule: ResolvedSchedule) -> CallPattern:
    """The call pattern of ``schedule`` over one hyperperiod, with peak and mean load.

    Every periodic function counts, stopped (``autorun=False``) ones included: they
    may be started at any time, so their slot is part of the static schedule.
    """
    h = schedule.hyperperiod_ticks
    ticks: list[list[str]] = [[] for _ in range(h)]
    for p in schedule.periodics:
        for k in range(p.offset, h, p.prescaler):
            ticks[k].append(p.fun)
    requests = [OffsetRequest(p.prescaler, None, p.cost) for p in schedule.periodics]
    offsets = [p.offset for p in schedule.periodics]
    counts = tick_loads(requests, offsets, unit_cost=True) if requests else np.zeros(1)
    costs = tick_loads(requests, offsets) if requests else np.zeros(1)
    return CallPattern(
        strategy=schedule.strategy,
        hyperperiod_ticks=h,
        ticks=tuple(tuple(t) for t in ticks),
        peak=int(counts.max()),
        mean=float(counts.mean()),
        peak_cost=float(costs.max()),
        mean_cost=float(costs.mean()),
    )


# ---------------------------------------------------------------------------------------
# Runtime: clock, statistics, scheduler


class Clock(Protocol):
    """Simulated time in integer microseconds (the PX4 side's unit)."""

    def now_us(self) -> int: ...


class ManualClock:
    """A clock that only moves when told to (tests, or a simulator that owns time)."""

    def __init__(self, start_us: int = 0) -> None:
        self._now_us = int(start_us)

    def now_us(self) -> int:
        return self._now_us

    def advance_us(self, dt_us: int) -> None:
        if dt_us < 0:
            raise ValueError(f"dt_us: {dt_us} must be >= 0")
        self._now_us += int(dt_us)

    def set_us(self, t_us: int) -> None:
        if t_us < self._now_us:
            raise ValueError(f"t_us: {t_us} is before the current time {self._now_us}")
        self._now_us = int(t_us)


def release_time_us(tick: int, main_freq_hz: int) -> int:
    """Simulated time (us) at which main-loop tick ``tick`` is due at ``main_freq_hz``."""
    return tick * 1_000_000 // main_freq_hz


class _ReleaseClock:
    """Default clock: every tick runs exactly at its release time ``k / main_freq``."""

    def __init__(self, scheduler: Scheduler) -> None:
        self._scheduler = scheduler

    def now_us(self) -> int:
        scheduler = self._scheduler
        return release_time_us(scheduler.tick_count, scheduler.schedule.main_freq_hz)


@dataclass(frozen=True)
class DutyWindow:
    """Host-time duty over one window of calls (seed 002, Figures 6-9), microseconds."""

    calls: int
    avg_us: float
    min_us: float
    max_us: float
    end_tick: int
    """Main-loop tick count when the window closed."""


@dataclass(frozen=True)
class DutyStats:
    """Completed windows plus the totals over every call so far."""

    windows: tuple[DutyWindow, ...]
    calls: int
    avg_us: float
    min_us: float
    max_us: float


@dataclass(frozen=True)
class FrequencyStats:
    """Achieved call frequency in simulated time (seed 002, Table 2)."""

    calls: int
    freq_hz: float
    """``(calls - 1) / (last - first call time)``; 0 with fewer than two calls."""
    interval_std_us: float
    """Standard deviation of the interval between calls (jitter), microseconds."""

    @property
    def std_hz(self) -> float:
        """Spread of the frequency, ``freq**2 * interval std`` (first-order propagation)."""
        return self.freq_hz**2 * self.interval_std_us * 1e-6


class TickResult(NamedTuple):
    """What one main-loop tick did (a named tuple: one is made every tick)."""

    tick: int
    time_us: int
    called: tuple[str, ...]
    """Periodic then event functions, in call order."""
    duty_ns: int
    overrun: bool


# TickResult from a tuple of its fields without the generated __new__'s Python frame (one
# is made every tick)
_new_tick_result: Callable[[tuple[int, int, tuple[str, ...], int, bool]], TickResult] = (
    functools.partial(tuple.__new__, TickResult))


@dataclass(frozen=True)
class SchedulerReport:
    """Duty (host time) and achieved frequencies (simulated time), as in Table 2."""

    main_freq_hz: int
    strategy: str
    ticks: int
    overruns: int
    """Ticks whose measured duty exceeded the main-loop period."""
    tick_duty: DutyStats
    group_duty: Mapping[TaskGroup, DutyStats]
    event_duty: DutyStats
    group_freq: Mapping[TaskGroup, FrequencyStats]
    function_freq: Mapping[str, FrequencyStats]
    event_poll_freq: FrequencyStats
    event_calls: Mapping[str, int]


class _DutyMeter:
    """Average/min/max of durations per window of ``window`` calls (host ns in, us out).

    A call only appends to the open window; the window's sum, min and max are taken
    (in C, by the builtins) when it closes, so measuring costs little next to what it
    measures (seed 002 keeps the measurement cheap for the same reason).
    """

    def __init__(self, window: int) -> None:
        self.window = window
        self._windows: list[DutyWindow] = []
        self.open: list[int] = []  # durations of the open window [host ns]
        self._total_n = self._total_sum = 0
        self._total_min = self._total_max = 0

    def record(self, duration_ns: int, tick: int) -> None:
        self.open.append(duration_ns)
        if len(self.open) >= self.window:
            self.close(tick)

    def add_window(self, durations: npt.NDArray[np.int64], tick: int) -> None:
        """Close a whole window of ``durations`` at once (the scheduler's tick-aligned
        meters, whose durations it keeps as host-clock marks until then)."""
        if len(durations):
            self._fold(len(durations), int(durations.sum()), int(durations.min()),
                       int(durations.max()), tick)

    def close(self, tick: int) -> None:
        """Close the open window at main-loop tick count ``tick``."""
        open_ = self.open
        self._fold(len(open_), sum(open_), min(open_), max(open_), tick)
        open_.clear()

    def _fold(self, n: int, total: int, lo: int, hi: int, tick: int) -> None:
        """Keep one closed window of ``n`` durations and add it to the totals."""
        self._windows.append(DutyWindow(n, total / n / 1e3, lo / 1e3, hi / 1e3, tick))
        if self._total_n == 0:
            self._total_min, self._total_max = lo, hi
        self._total_n += n
        self._total_sum += total
        self._total_min = min(self._total_min, lo)
        self._total_max = max(self._total_max, hi)

    def stats(self, pending: Sequence[int] = ()) -> DutyStats:
        """Every duration so far: the closed windows, the open one and ``pending``
        (durations not handed over yet)."""
        n, total = self._total_n, self._total_sum
        lo, hi = self._total_min, self._total_max
        if self.open or len(pending):
            o = [*self.open, *pending]
            lo = min(o) if n == 0 else min(lo, min(o))
            hi = max(o) if n == 0 else max(hi, max(o))
            n += len(o)
            total += sum(o)
        return DutyStats(
            windows=tuple(self._windows),
            calls=n,
            avg_us=total / n / 1e3 if n else 0.0,
            min_us=lo / 1e3,
            max_us=hi / 1e3,
        )


_INT64_LIMIT = 2**63  # the squared intervals are summed in int64 while they stay below it


class _RateMeter:
    """Call times in simulated microseconds -> achieved frequency and its spread.

    Times are buffered and folded into integer sums of the intervals and of their
    squares every ``_FOLD`` calls (exact: the times are integers)."""

    FOLD = 1024

    def __init__(self) -> None:
        self.calls = 0
        self._first_us: int | None = None
        self._last_us = 0
        self._n = self._sum = self._sumsq = 0  # intervals, folded
        self.times: list[int] = []  # call times not folded yet

    def record(self, t_us: int) -> None:
        self.times.append(t_us)
        if len(self.times) >= self.FOLD:
            self._fold()

    def fold_if_full(self) -> None:
        """Fold the buffered times once there are ``FOLD`` of them (callers that append
        to :attr:`times` directly call this now and then)."""
        if len(self.times) >= self.FOLD:
            self._fold()

    def _fold(self) -> None:
        times = self.times
        if not times:
            return
        if self._first_us is None:
            self._first_us = times[0]
            previous = times[0]
            rest = times[1:]
        else:
            previous = self._last_us
            rest = times
        intervals = np.diff(np.array([previous, *rest], dtype=np.int64))
        self._n += len(intervals)
        self._sum += int(intervals.sum())
        largest = int(np.abs(intervals).max()) if len(intervals) else 0
        if largest * largest * len(intervals) < _INT64_LIMIT:
            self._sumsq += int(np.dot(intervals, intervals))  # exact in int64
        else:  # long intervals: Python's integers, which do not overflow
            self._sumsq += sum(i * i for i in intervals.tolist())
        self.calls += len(times)
        self._last_us = times[-1]
        times.clear()

    def stats(self) -> FrequencyStats:
        self._fold()
        first = self._first_us if self._first_us is not None else 0
        span = self._last_us - first
        freq = (self.calls - 1) * 1e6 / span if self.calls > 1 and span > 0 else 0.0
        n = self._n
        # population variance of the intervals, exact in integers until the square root
        std = math.sqrt(n * self._sumsq - self._sum * self._sum) / n if n > 1 else 0.0
        return FrequencyStats(self.calls, freq, std)


class Scheduler:
    """Runs a :class:`ResolvedSchedule` tick by tick (seed 002, Figure 4's main loop).

    ``functions`` binds every declared init, periodic and event function name to a
    callable taking no argument; a missing or unknown name is a BindingError. ``clock``
    gives the simulated time stamped on calls (default: each tick runs exactly at its
    release time); ``host_timer`` (ns) measures duty only.

    Call :meth:`init` once, then :meth:`tick` per main-loop period, or :meth:`run_until`
    with the simulated time to run every tick released by then.
    """

    def __init__(
        self,
        schedule: ResolvedSchedule,
        functions: Mapping[str, Callable[[], object]],
        *,
        clock: Clock | None = None,
        host_timer: Callable[[], int] = time.perf_counter_ns,
        window_calls: int = DEFAULT_WINDOW_CALLS,
    ) -> None:
        if window_calls < 1:
            raise SchedulerError(f"window_calls: {window_calls} must be >= 1")
        declared = [c.fun for c in schedule.inits]
        declared += [p.fun for p in schedule.periodics] + [e.fun for e in schedule.events]
        missing = sorted(set(declared) - set(functions))
        unknown = sorted(set(functions) - set(declared))
        if missing or unknown:
            raise BindingError(
                f"function bindings do not match the schedule: missing {missing}, "
                f"not declared by any selected module {unknown}"
            )
        self.schedule = schedule
        self._functions = dict(functions)
        self._clock: Clock = clock if clock is not None else _ReleaseClock(self)
        self._timer = host_timer
        self._period_ns = schedule.tick_period_ns
        self._groups = tuple(
            (g, tuple(p for p in schedule.periodics if p.group is g))
            for g in TASK_GROUP_ORDER
            if any(p.group is g for p in schedule.periodics)
        )
        self._running = {p.fun: p.autorun for p in schedule.periodics}
        self._stopped = {fun for fun, running in self._running.items() if not running}
        self._flags = {e.fun: False for e in schedule.events}
        self._events = tuple(e.fun for e in schedule.events)  # in poll order
        self._initialised = False
        self._tick = 0
        self._overruns = 0
        self._window = window_calls
        self._tick_duty = _DutyMeter(window_calls)
        self._group_duty = {g: _DutyMeter(window_calls) for g, _ in self._groups}
        self._event_duty = _DutyMeter(window_calls)
        # host-clock marks of the ticks of the open window, flat: per tick its start, the
        # end of each group, the end of the event poll; the tick's, the groups' and the
        # poll's durations are their differences, taken when the window closes
        self._marks: list[int] = []
        self._marks_per_tick = len(self._groups) + 2
        # every group runs on every tick, at the tick's time: one rate meter serves them all
        self._tick_rate = _RateMeter()
        self._fun_rate = {p.fun: _RateMeter() for p in schedule.periodics}
        self._poll_rate = _RateMeter()
        self._rate_meters = (self._tick_rate, *self._fun_rate.values(), self._poll_rate)
        self._tick_times = self._tick_rate.times  # the meters fold and clear these lists,
        self._poll_times = self._poll_rate.times  # never replace them
        self._event_calls = dict.fromkeys(self._flags, 0)
        # per group, (name, prescaler, offset, callable, call-time list) per function; the
        # functions due at a tick depend only on the tick modulo the prescalers' least
        # common multiple
        self._plan = tuple(
            tuple((p.fun, p.prescaler, p.offset, self._functions[p.fun],
                   self._fun_rate[p.fun].times) for p in periodics)
            for _, periodics in self._groups
        )
        self._cycle = math.lcm(*(p.prescaler for p in schedule.periodics)) if (
            schedule.periodics) else 1
        self._phases: dict[int, tuple[Any, ...]] = {}

    # -- lifecycle ------------------------------------------------------------------

    def init(self) -> None:
        """Call every init function once, in task-group then module order."""
        if self._initialised:
            raise SchedulerError("init() was already called")
        for call in self.schedule.inits:
            self._functions[call.fun]()
        self._initialised = True

    @property
    def tick_count(self) -> int:
        """Main-loop ticks run so far (the index of the next tick)."""
        return self._tick

    def release_time_us(self, tick: int) -> int:
        """Simulated time (us) at which main-loop tick ``tick`` is due."""
        return release_time_us(tick, self.schedule.main_freq_hz)

    # -- periodic and event functions -------------------------------------------------

    def start(self, fun: str) -> None:
        """Start a periodic function (Paparazzi's MODULES_START)."""
        self._require(fun, self._running, "periodic")
        self._running[fun] = True
        self._stopped.discard(fun)

    def stop(self, fun: str) -> None:
        """Stop a periodic function; its slot stays reserved (MODULES_STOP)."""
        self._require(fun, self._running, "periodic")
        self._running[fun] = False
        self._stopped.add(fun)

    def is_running(self, fun: str) -> bool:
        self._require(fun, self._running, "periodic")
        return self._running[fun]

    def set_event(self, fun: str) -> None:
        """Flag event function ``fun``: it is called once at the next event poll."""
        self._require(fun, self._flags, "event")
        self._flags[fun] = True

    def poll_events(self) -> tuple[str, ...]:
        """Call the flagged event functions (group then module order), clear their flags."""
        called: list[str] = []
        t0 = self._timer()
        self._run_events(called)
        self._event_duty.record(self._timer() - t0, self._tick)
        self._poll_rate.record(self._clock.now_us())
        return tuple(called)

    def _run_events(self, called: list[str]) -> None:
        flags = self._flags
        for fun in self._events:
            if flags[fun]:
                flags[fun] = False
                self._functions[fun]()
                self._event_calls[fun] += 1
                called.append(fun)

    def _phase(self, phase: int) -> tuple[tuple[Any, ...], tuple[str, ...]]:
        """Per group, the functions due at ``phase`` (name, callable, call-time list), and
        all their names in call order."""
        plan = self._phases.get(phase)
        if plan is None:
            groups = tuple(
                tuple((fun, call, times) for fun, prescaler, offset, call, times in periodics
                      if phase % prescaler == offset)
                for periodics in self._plan)
            plan = groups, tuple(fun for due in groups for fun, _, _ in due)
            if len(self._phases) < _PHASES_CACHED:
                self._phases[phase] = plan
        return plan

    def _close_window(self, tick: int) -> None:
        """Hand the open window's durations, from its host-clock marks, to the meters."""
        tick_duty, groups, events = self._window_durations()
        self._tick_duty.add_window(tick_duty, tick)
        for i, meter in enumerate(self._group_duty.values()):
            meter.add_window(groups[:, i], tick)
        # the ticks' event polls close with their window; polls between ticks
        # (poll_events) went into the open window when they ran
        if self._event_duty.open:
            for d in events.tolist():
                self._event_duty.record(d, tick)
        else:
            self._event_duty.add_window(events, tick)
        self._marks.clear()
        for rate_meter in self._rate_meters:  # the call times they hold, folded when many
            rate_meter.fold_if_full()

    def _window_durations(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64],
                                          npt.NDArray[np.int64]]:
        """The open window's tick, group (one column each) and event-poll durations [ns]."""
        width = self._marks_per_tick
        complete = len(self._marks) - len(self._marks) % width  # not a tick under way
        marks = np.fromiter(self._marks, dtype=np.int64, count=complete).reshape(-1, width)
        steps = np.diff(marks, axis=1)
        return marks[:, -1] - marks[:, 0], steps[:, :-1], steps[:, -1]

    def tick(self) -> TickResult:
        """One main-loop iteration: due periodic functions group by group, then events.

        Duty is measured per task group (each group with periodic functions is timed on
        every tick, as Paparazzi times its group functions) and for the whole tick; a
        tick longer than the main-loop period counts as an overrun. One host-clock read
        per group boundary: a group's duty runs from the previous boundary to its end; a
        group with nothing due on the tick, or an event poll with no event functions,
        does nothing and takes 0 (its boundary is the previous one, not read again).
        The tick only appends the marks (and the call times); every ``window_calls`` ticks
        the meters take the window's durations from them at once.
        """
        if not self._initialised:
            raise SchedulerError("init() must be called before tick()")
        k = self._tick
        now = self._clock.now_us()
        timer = self._timer
        marks = self._marks
        mark = marks.append
        phase = k % self._cycle
        groups, called = self._phases.get(phase) or self._phase(phase)
        stopped = self._stopped
        skipped: list[str] = []  # due but stopped when their turn came
        mark(t := timer())
        tick_start = t
        try:
            for due in groups:
                if due:
                    for fun, call, times in due:
                        if stopped and fun in stopped:
                            skipped.append(fun)
                            continue
                        call()
                        times.append(now)
                    t = timer()
                mark(t)
            if self._events:
                events: list[str] = []
                self._run_events(events)
                called += tuple(events)
                t = timer()
        except BaseException:  # the tick did not happen: drop its marks, keep the rows
            del marks[len(marks) - len(marks) % self._marks_per_tick:]
            raise
        mark(t_end := t)
        if skipped:
            called = tuple(fun for fun in called if fun not in skipped)
        self._tick_times.append(now)
        self._poll_times.append(now)
        duty_ns = t_end - tick_start
        overrun = duty_ns > self._period_ns
        self._overruns += overrun
        self._tick = k + 1
        if self._tick % self._window == 0:
            self._close_window(k + 1)
        return _new_tick_result((k, now, called, duty_ns, overrun))

    def run_until(self, now_us: int) -> int:
        """Run every tick released at or before simulated time ``now_us``; return how many.

        Late ticks (the caller's step longer than the main-loop period) run back to back
        and are stamped with the clock's time, which the achieved frequencies then show.
        """
        ran = 0
        while self.release_time_us(self._tick) <= now_us:
            self.tick()
            ran += 1
        return ran

    # -- statistics -------------------------------------------------------------------

    def report(self) -> SchedulerReport:
        """Duty and frequency statistics so far."""
        tick_duty, groups, events = self._window_durations()
        group_freq = self._tick_rate.stats()
        return SchedulerReport(
            main_freq_hz=self.schedule.main_freq_hz,
            strategy=self.schedule.strategy,
            ticks=self._tick,
            overruns=self._overruns,
            tick_duty=self._tick_duty.stats(tick_duty.tolist()),
            group_duty={g: m.stats(groups[:, i].tolist())
                        for i, (g, m) in enumerate(self._group_duty.items())},
            event_duty=self._event_duty.stats(events.tolist()),
            group_freq=dict.fromkeys(self._group_duty, group_freq),
            function_freq={f: m.stats() for f, m in self._fun_rate.items()},
            event_poll_freq=self._poll_rate.stats(),
            event_calls=dict(self._event_calls),
        )

    @staticmethod
    def _require(fun: str, table: Mapping[str, object], kind: str) -> None:
        if fun not in table:
            raise BindingError(f"no {kind} function {fun!r} in the schedule")
