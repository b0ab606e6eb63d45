"""Seeded synthetic time-sync traces and the replay metrics shared by tests and the bench.

A trace is a run of timesync request/reply exchanges between the companion computer (the
local clock, which is also the reference "true" time) and the flight controller (the
remote clock)::

    ts1_us   local clock when the request leaves the companion      (seed: T_Packet Creation)
    tc1_us   remote clock when the FCU stamps the request            (seed: T_Remote Stamp)
    now_us   local clock when the reply is back at the companion     (seed: T_Current)

The true offset is ``local - remote`` (PX4's sign: ``local = remote + offset``) and is
modelled as ``offset0_us + skew_ppm * 1e-6 * (t - t_start) + jump_us * [t >= t_jump]``.

One-way latencies follow seed 000 Table 3 for the MicroXRCE-DDS bridge: companion -> FCU
1329 +/- 162 us, FCU -> companion 1752 +/- 315 us (mean +/- standard deviation). The table
gives only the first two moments, so the shape is a choice: a shifted gamma distribution
with the table's mean and standard deviation (a hard floor plus a right tail, as OS and
serial-link latency looks); ``shape`` sets the tail, large values approach a Gaussian.
Load spikes add 5-50 ms to one leg of an exchange; a clock jump steps the remote clock.

Everything here is pure (numpy only) and deterministic for a given ``numpy.random.Generator``.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from flight_control.errors import TimesyncParameterError
from interfaces.px4.seed000 import TABLE3_TO_COMPANION, TABLE3_TO_FCU
from interfaces.px4.timesync import TimesyncEstimate, TimesyncEstimator

__all__ = [
    "CONVERGENCE_TOLERANCE_US",
    "SCENARIOS",
    "SEED_COMPANION_TO_FCU",
    "SEED_FCU_TO_COMPANION",
    "LatencyModel",
    "ReplayMetrics",
    "ReplayResult",
    "Scenario",
    "TimesyncTrace",
    "TraceConfig",
    "TraceSample",
    "generate_trace",
    "replay",
    "replay_metrics",
    "settling_sample",
]

CONVERGENCE_TOLERANCE_US = 50.0  # settling band of the error around its steady median [us]

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class LatencyModel:
    """One-way latency: ``floor + Gamma(shape, scale)`` with the given mean and std [us]."""

    mean_us: float
    std_us: float
    shape: float = 4.0  # gamma shape k (skewness 2/sqrt(k)); > 0, large k ~ Gaussian

    def __post_init__(self) -> None:
        if not self.std_us > 0.0:
            raise TimesyncParameterError(f"std_us={self.std_us!r}: must be > 0 us")
        if not self.shape > 0.0:
            raise TimesyncParameterError(f"shape={self.shape!r}: must be > 0")
        if self.floor_us < 0.0:
            raise TimesyncParameterError(
                f"mean_us={self.mean_us!r}, std_us={self.std_us!r}, shape={self.shape!r}: "
                f"floor mean - std*sqrt(shape) = {self.floor_us:.1f} us must be >= 0"
            )

    @property
    def floor_us(self) -> float:
        """The smallest latency the model can produce [us]."""
        return self.mean_us - self.std_us * float(np.sqrt(self.shape))

    def sample(self, rng: np.random.Generator, n: int) -> FloatArray:
        """Draw ``n`` latencies [us, float]."""
        scale = self.std_us / float(np.sqrt(self.shape))
        return self.floor_us + rng.gamma(self.shape, scale, size=n)


# Seed 000, Table 3, MicroXRCE-DDS-ROS 2 row (mean +/- std, us).
SEED_COMPANION_TO_FCU = LatencyModel(mean_us=TABLE3_TO_FCU.mean_us, std_us=TABLE3_TO_FCU.sd_us)
SEED_FCU_TO_COMPANION = LatencyModel(mean_us=TABLE3_TO_COMPANION.mean_us,
                                     std_us=TABLE3_TO_COMPANION.sd_us)


@dataclass(frozen=True, slots=True)
class TraceConfig:
    """Keyword-configured trace; every time is int microseconds of the local clock."""

    n_samples: int = 3000
    period_us: int = 5_000  # 200 Hz, the seed's exchange rate (Algorithms 1-2 timers)
    start_local_us: int = 50_000_000  # companion uptime at the first request
    offset0_us: int = 30_123_456  # true local - remote at the first request
    skew_ppm: float = 0.0  # d(offset)/d(local time), parts per million
    outbound: LatencyModel = SEED_COMPANION_TO_FCU
    inbound: LatencyModel = SEED_FCU_TO_COMPANION
    spike_probability: float = 0.0  # per exchange, in [0, 1]
    spike_min_us: int = 5_000
    spike_max_us: int = 50_000
    jump_at_sample: int | None = None  # remote clock steps from this request on
    jump_us: int = 0  # added to the true offset at the jump

    def __post_init__(self) -> None:
        _require(self.n_samples >= 1, "n_samples", self.n_samples, ">= 1")
        _require(self.period_us >= 1, "period_us", self.period_us, ">= 1 us")
        _require(0.0 <= self.spike_probability <= 1.0, "spike_probability",
                 self.spike_probability, "in [0, 1]")
        _require(0 <= self.spike_min_us <= self.spike_max_us, "spike_min_us",
                 self.spike_min_us, "in [0, spike_max_us]")
        if self.jump_at_sample is not None:
            _require(0 <= self.jump_at_sample < self.n_samples, "jump_at_sample",
                     self.jump_at_sample, f"in [0, {self.n_samples})")


def _require(ok: bool, key: str, value: object, allowed: str) -> None:
    if not ok:
        raise TimesyncParameterError(f"{key}={value!r}: must be {allowed}")


class TraceSample(NamedTuple):
    """One exchange as the estimator sees it, plus the truth at ``now_us``."""

    ts1_us: int
    tc1_us: int
    now_us: int
    true_offset_us: int


@dataclass(frozen=True, slots=True, eq=False)
class TimesyncTrace:
    """A generated trace: parallel int64 arrays, one entry per exchange."""

    config: TraceConfig
    ts1_us: IntArray
    tc1_us: IntArray
    now_us: IntArray
    true_offset_us: IntArray  # true local - remote at now_us
    spike: npt.NDArray[np.bool_]  # whether a load spike hit this exchange

    def __len__(self) -> int:
        return int(self.ts1_us.shape[0])

    def __iter__(self) -> Iterator[TraceSample]:
        for a, b, c, d in zip(self.ts1_us.tolist(), self.tc1_us.tolist(),
                              self.now_us.tolist(), self.true_offset_us.tolist(), strict=True):
            yield TraceSample(a, b, c, d)

    @property
    def rtt_us(self) -> IntArray:
        return self.now_us - self.ts1_us


def _true_offset_us(config: TraceConfig, t_us: FloatArray, t_jump_us: float | None) -> FloatArray:
    offset = config.offset0_us + config.skew_ppm * 1e-6 * (t_us - config.start_local_us)
    if t_jump_us is not None:
        offset = offset + np.where(t_us >= t_jump_us, float(config.jump_us), 0.0)
    return np.asarray(offset, dtype=np.float64)


def generate_trace(config: TraceConfig, rng: np.random.Generator) -> TimesyncTrace:
    """Generate the exchanges described by ``config`` drawing only from ``rng``."""
    n = config.n_samples
    ts1 = config.start_local_us + config.period_us * np.arange(n, dtype=np.int64)
    d_out = config.outbound.sample(rng, n)
    d_in = config.inbound.sample(rng, n)
    spike = rng.random(n) < config.spike_probability
    spike_size = rng.uniform(config.spike_min_us, config.spike_max_us, size=n)
    spike_on_outbound = rng.random(n) < 0.5
    d_out = d_out + np.where(spike & spike_on_outbound, spike_size, 0.0)
    d_in = d_in + np.where(spike & ~spike_on_outbound, spike_size, 0.0)

    t_jump = None if config.jump_at_sample is None else float(ts1[config.jump_at_sample])
    arrival = ts1 + d_out  # true (local) time the request reaches the FCU
    tc1 = np.floor(arrival - _true_offset_us(config, arrival, t_jump)).astype(np.int64)
    now = np.floor(arrival + d_in).astype(np.int64)
    true_offset = np.round(_true_offset_us(config, now.astype(np.float64), t_jump))
    return TimesyncTrace(
        config=config,
        ts1_us=ts1,
        tc1_us=tc1,
        now_us=now,
        true_offset_us=true_offset.astype(np.int64),
        spike=spike,
    )


@dataclass(frozen=True, slots=True, eq=False)
class ReplayResult:
    """Every estimate an estimator produced over a trace, and its error against the truth."""

    estimates: tuple[TimesyncEstimate, ...]
    offset_us: IntArray  # estimated offset after each update
    error_us: IntArray  # estimated - true offset after each update
    skew_ppm: FloatArray


def replay(estimator: TimesyncEstimator, trace: TimesyncTrace) -> ReplayResult:
    """Feed every exchange of ``trace`` to ``estimator`` in order."""
    estimates = tuple(estimator.update(s.ts1_us, s.tc1_us, s.now_us) for s in trace)
    offset = np.array([e.offset_us for e in estimates], dtype=np.int64)
    return ReplayResult(
        estimates=estimates,
        offset_us=offset,
        error_us=offset - trace.true_offset_us,
        skew_ppm=np.array([e.skew_ppm for e in estimates], dtype=np.float64),
    )


def settling_sample(
    error_us: Sequence[int] | IntArray, tolerance_us: float, reference_us: float = 0.0
) -> int | None:
    """First index from which ``|error - reference|`` stays within ``tolerance_us`` to the end.

    ``None`` when the last error is outside the band (it never settled).
    """
    err = np.abs(np.asarray(error_us, dtype=np.float64) - reference_us)
    outside = np.flatnonzero(err > tolerance_us)
    if outside.size == 0:
        return 0
    last = int(outside[-1])
    return None if last == err.size - 1 else last + 1


@dataclass(frozen=True, slots=True)
class ReplayMetrics:
    """Convergence and steady-state figures of one replay segment.

    Convergence is settling: the samples into the segment until the error stays within
    ``tolerance_us`` of its own steady-state median. The median itself (``steady_bias_us``)
    is mostly the path asymmetry, which no two-way exchange can observe; it is reported,
    and it is inside the absolute errors ``steady_p50_us`` / ``steady_p99_us`` (against the
    true offset), but it does not delay convergence.
    """

    convergence_samples: int | None
    steady_p50_us: float  # median |estimate - true offset| over the steady tail
    steady_p99_us: float  # 99th percentile of the same
    steady_bias_us: float  # median signed error over the tail
    jitter_p99_us: float  # 99th percentile |error - steady_bias| over the tail
    skew_error_p50_ppm: float  # median |estimated - true skew| over the tail
    skew_error_p99_ppm: float


def replay_metrics(
    result: ReplayResult,
    trace: TimesyncTrace,
    *,
    steady_from: int,
    segment_start: int = 0,
    tolerance_us: float = CONVERGENCE_TOLERANCE_US,
) -> ReplayMetrics:
    """Metrics of the replay from ``segment_start``; the steady tail starts at ``steady_from``."""
    n = len(result.error_us)
    _require(0 <= segment_start <= steady_from < n, "steady_from", steady_from,
             f"in [segment_start={segment_start}, {n})")
    tail = np.asarray(result.error_us[steady_from:], dtype=np.float64)
    bias = float(np.median(tail))
    skew_err = np.abs(result.skew_ppm[steady_from:] - trace.config.skew_ppm)
    return ReplayMetrics(
        convergence_samples=settling_sample(result.error_us[segment_start:], tolerance_us, bias),
        steady_p50_us=float(np.percentile(np.abs(tail), 50)),
        steady_p99_us=float(np.percentile(np.abs(tail), 99)),
        steady_bias_us=bias,
        jitter_p99_us=float(np.percentile(np.abs(tail - bias), 99)),
        skew_error_p50_ppm=float(np.percentile(skew_err, 50)),
        skew_error_p99_ppm=float(np.percentile(skew_err, 99)),
    )


@dataclass(frozen=True, slots=True)
class Scenario:
    """A trace configuration and the replay segments its metrics are taken over."""

    description: str
    config: TraceConfig
    segment_start: int = 0  # convergence is counted from here (the jump, if any)
    steady_from: int = 4_000  # steady-state tail starts here


_CLOCK_JUMP_AT = 4_000

# The bench's and tests' shared scenarios (200 Hz exchanges, seed 000 Table 3 latencies).
SCENARIOS: Mapping[str, Scenario] = MappingProxyType({
    "nominal": Scenario(
        "Table 3 latencies, no skew, no spikes", TraceConfig(n_samples=8_000)),
    "skew_50ppm": Scenario(
        "nominal + 50 ppm clock skew", TraceConfig(n_samples=8_000, skew_ppm=50.0)),
    "spikes": Scenario(
        "nominal + 20 ppm skew + 5-50 ms load spikes on 5% of exchanges",
        TraceConfig(n_samples=8_000, skew_ppm=20.0, spike_probability=0.05)),
    "clock_jump": Scenario(
        "nominal + remote clock steps +250 ms at sample 4000 (> the 100 ms deviation gate)",
        TraceConfig(n_samples=10_000, jump_at_sample=_CLOCK_JUMP_AT, jump_us=250_000),
        segment_start=_CLOCK_JUMP_AT, steady_from=7_000),
    "clock_jump_5ms": Scenario(
        "nominal + remote clock steps +5 ms at sample 4000 (under PX4's 100 ms gate)",
        TraceConfig(n_samples=10_000, jump_at_sample=_CLOCK_JUMP_AT, jump_us=5_000),
        segment_start=_CLOCK_JUMP_AT, steady_from=7_000),
    "symmetric": Scenario(
        "both legs 1329 +/- 162 us: no path asymmetry, so the error is the estimator's own",
        TraceConfig(n_samples=8_000, inbound=SEED_COMPANION_TO_FCU)),
    "near_gaussian": Scenario(
        "Table 3 moments with a thin tail (gamma shape 25, skewness 0.4)",
        TraceConfig(n_samples=8_000,
                    outbound=replace(SEED_COMPANION_TO_FCU, shape=25.0),
                    inbound=replace(SEED_FCU_TO_COMPANION, shape=25.0))),
})
