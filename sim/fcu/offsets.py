"""Offset strategies: on which tick of its prescaler period each periodic function runs.

A function with prescaler ``p`` and offset ``o`` runs on main-loop ticks ``k`` with
``k % p == o``. The offset is free (seed 002, section 4.3): it changes which functions
share a tick, hence the peak work per tick, not the rate. Strategies are chosen by name
from :data:`OFFSET_STRATEGIES`:

``naive``
    The seed's (Paparazzi's) rule: the n-th function without a user ``delay``, in
    resolved module order, gets ``x = (n mod 10) / 10`` of its period (0.1, 0.2, ...,
    0.9, 0.0, 0.1, ...); execution time is ignored.
``balanced``
    Ours: greedy least-loaded phase assignment over the hyperperiod, then local search;
    see :class:`BalancedOffsets`.

Offsets pinned by a module's ``delay`` are kept by every strategy.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from sim.fcu.errors import RateError, SchedulerError, UnknownStrategyError

MAX_HYPERPERIOD_TICKS = 5_000_000
"""Longest hyperperiod (ticks) the load analysis walks; beyond it the rates are rejected."""

_EPS = 1e-9


@dataclass(frozen=True)
class OffsetRequest:
    """What a strategy sees of one periodic function."""

    prescaler: int
    """Main-loop ticks between two calls (>= 1)."""
    pinned: int | None = None
    """Offset fixed by the module's ``delay``, or None if the strategy chooses."""
    cost: float = 1.0
    """Relative execution cost (>= 0)."""


@runtime_checkable
class OffsetStrategy(Protocol):
    """Assigns an offset in ``[0, prescaler)`` to every request, keeping pinned ones."""

    name: str

    def assign(self, requests: Sequence[OffsetRequest]) -> tuple[int, ...]:
        """One offset per request, in the order given (resolved module order)."""
        ...


def delay_to_offset(delay: float, prescaler: int) -> int:
    """``floor(delay * prescaler)``: the tick within the period a delay in [0, 1) means."""
    return min(prescaler - 1, math.floor(delay * prescaler + _EPS))


def hyperperiod(prescalers: Iterable[int], limit: int = MAX_HYPERPERIOD_TICKS) -> int:
    """Least common multiple of the prescalers (1 if none), in main-loop ticks."""
    h = math.lcm(1, *prescalers)
    if h > limit:
        raise RateError(
            f"hyperperiod of {h} ticks exceeds {limit}: choose rates whose prescalers "
            "share factors (e.g. divisors of the main-loop frequency)"
        )
    return h


def tick_loads(
    requests: Sequence[OffsetRequest], offsets: Sequence[int], *, unit_cost: bool = False
) -> npt.NDArray[np.float64]:
    """Summed cost (or count, with ``unit_cost``) of the functions due on each tick of
    one hyperperiod."""
    loads = np.zeros(hyperperiod(r.prescaler for r in requests), dtype=np.float64)
    for request, offset in zip(requests, offsets, strict=True):
        loads[offset :: request.prescaler] += 1.0 if unit_cost else request.cost
    return loads


class NaiveOffsets:
    """The seed's offsets: ``x`` steps by 0.1 for each function without a user delay.

    Follows Paparazzi's generator (``gen_modules.ml``): the counter starts at 0 and is
    incremented *before* use, wraps to 0 after 0.9, advances for every periodic function
    without a ``delay`` (full-rate ones included) in resolved module order, and the
    offset is ``floor(x * prescaler)``. Tenths are exact here; Paparazzi accumulates
    floats, so its 8th offset is ``floor(0.7999... * p)``.
    """

    name = "naive"

    def assign(self, requests: Sequence[OffsetRequest]) -> tuple[int, ...]:
        offsets: list[int] = []
        tenths = 0
        for request in requests:
            if request.pinned is not None:
                offsets.append(request.pinned)
                continue
            tenths = (tenths + 1) % 10
            offsets.append(tenths * request.prescaler // 10)
        return tuple(offsets)


@dataclass(frozen=True)
class BalancedOffsets:
    """Greedy least-loaded phase assignment over the hyperperiod, then local search.

    1. Pinned functions are placed first. The others, most frequent first (fewest
       choices) and, within a rate, most costly first, each take the offset whose ticks
       have the lowest peak load so far, ties broken by the lowest total load on those
       ticks, then the lowest offset.
    2. Local search: each free function in turn is lifted out and put back at the offset
       that lowers ``(peak load, sum of squared loads)`` the most; passes repeat until no
       move helps. That objective strictly decreases, so the search ends.
    3. The search is also run from the naive offsets and the better of the two results
       kept, so the peak is never above the naive one.

    Loads are costs (``PeriodicSpec.cost``); with the default unit costs they are the
    number of functions per tick. Precedence between functions of different rates is
    not modelled (neither is it by the seed): a 250 Hz consumer may land one tick after
    its 250 Hz producer.
    """

    name = "balanced"
    max_passes: int = 50

    def assign(self, requests: Sequence[OffsetRequest]) -> tuple[int, ...]:
        if not requests:
            return ()
        h = hyperperiod(r.prescaler for r in requests)
        free = sorted(
            (i for i, r in enumerate(requests) if r.pinned is None),
            key=lambda i: (requests[i].prescaler, -requests[i].cost, i),
        )
        best: tuple[int, ...] | None = None
        best_score = (math.inf, math.inf)
        for start in (self._greedy(requests, h, free), NaiveOffsets().assign(requests)):
            offsets = self._improve(requests, list(start), h, free)
            loads = tick_loads(requests, offsets)
            score = (float(loads.max()), float(np.dot(loads, loads)))
            if _better(score, best_score):
                best, best_score = offsets, score
        assert best is not None
        return best

    @staticmethod
    def _greedy(requests: Sequence[OffsetRequest], h: int, free: Sequence[int]) -> list[int]:
        offsets = [r.pinned if r.pinned is not None else 0 for r in requests]
        loads = np.zeros(h, dtype=np.float64)
        for request in requests:
            if request.pinned is not None:
                loads[request.pinned :: request.prescaler] += request.cost
        for i in free:
            p, cost = requests[i].prescaler, requests[i].cost
            columns = loads.reshape(h // p, p)  # column o = the ticks offset o hits
            order = np.lexsort((np.arange(p), _q(columns.sum(axis=0)), _q(columns.max(axis=0))))
            offsets[i] = int(order[0])
            loads[offsets[i] :: p] += cost
        return offsets

    def _improve(
        self, requests: Sequence[OffsetRequest], offsets: list[int], h: int, free: Sequence[int]
    ) -> tuple[int, ...]:
        loads = tick_loads(requests, offsets)
        for _ in range(self.max_passes):
            moved = False
            for i in free:
                p, cost, current = requests[i].prescaler, requests[i].cost, offsets[i]
                if p == 1 or cost == 0:
                    continue
                loads[current::p] -= cost
                columns = loads.reshape(h // p, p)
                peak_if = np.maximum(loads.max(), columns.max(axis=0) + cost)
                total = columns.sum(axis=0)  # sum of squares grows by 2*cost*total + const
                order = np.lexsort((np.arange(p), _q(total), _q(peak_if)))
                candidate = int(order[0])
                if _better(
                    (peak_if[candidate], total[candidate]), (peak_if[current], total[current])
                ):
                    offsets[i] = candidate
                    moved = True
                loads[offsets[i] :: p] += cost
            if not moved:
                break
        return tuple(offsets)


def _q(values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Values rounded so that float noise does not break ties."""
    return np.round(values, 9)


def _better(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Lexicographic ``a < b`` with a tolerance on each component."""
    if a[0] < b[0] - _EPS:
        return True
    return abs(a[0] - b[0]) <= _EPS and a[1] < b[1] - _EPS


OFFSET_STRATEGIES: Mapping[str, OffsetStrategy] = MappingProxyType(
    {"naive": NaiveOffsets(), "balanced": BalancedOffsets()}
)
"""The offset strategies, by the name a configuration gives."""


def get_strategy(strategy: str | OffsetStrategy) -> OffsetStrategy:
    """The strategy registered under ``strategy``, or ``strategy`` itself."""
    if not isinstance(strategy, str):
        return strategy
    try:
        return OFFSET_STRATEGIES[strategy]
    except KeyError:
        allowed = ", ".join(OFFSET_STRATEGIES)
        raise UnknownStrategyError(
            f"unknown offset strategy {strategy!r}; allowed: {allowed}"
        ) from None


def checked_offsets(strategy: OffsetStrategy, requests: Sequence[OffsetRequest]) -> tuple[int, ...]:
    """Run ``strategy`` and check its answer (one offset per request, in range, pins kept)."""
    offsets = tuple(strategy.assign(requests))
    if len(offsets) != len(requests):
        raise SchedulerError(
            f"offset strategy {strategy.name!r} returned {len(offsets)} offsets "
            f"for {len(requests)} functions"
        )
    for n, (request, offset) in enumerate(zip(requests, offsets, strict=True)):
        if not 0 <= offset < request.prescaler or (
            request.pinned is not None and offset != request.pinned
        ):
            raise SchedulerError(
                f"offset strategy {strategy.name!r} gave offset {offset} to function {n} "
                f"(prescaler {request.prescaler}, pinned {request.pinned})"
            )
    return offsets
