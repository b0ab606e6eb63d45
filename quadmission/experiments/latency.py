"""Seed 000's FCU <-> companion latency test (sections 2.9-3.2, Table 3) in our SITL.

Two 200 Hz streams of 115-byte messages cross the simulated serial link
(:mod:`sim.fcu.link`), calibrated so that the figures this experiment measures are Table 3's
MicroXRCE-DDS - ROS 2 row (:data:`interfaces.px4.seed000.TABLE3_TO_FCU`, ``_TO_COMPANION``):

============  ============================================  ==================================
path          stream                                        latency, measured where
============  ============================================  ==================================
forward       companion -> FCU ``vehicle_visual_odometry``  FCU estimator consumes it (FCU
              created by :class:`~flight_control.latency_  clock) minus the creation time on
              node.LatencyTestNode`                         the FCU clock (seed eq. 10)
reverse       FCU -> companion ``sensor_combined``          companion node receives it
              stamped on the FCU clock at the IMU read      (companion clock) minus the stamp
                                                            on the companion clock (eq. 11)
============  ============================================  ==================================

*Corrected* figures convert the companion's clock to the FCU's (or back) with a time-sync
estimator; ``"px4"`` (seed Algorithm 3) and ``"kalman"`` run side by side on the same
Timesync exchanges. *Uncorrected* figures subtract the raw stamps: they carry the whole
clock offset (the FCU booted ~25 s before the companion's clock started, and runs 20 ppm
fast), which is the point of the comparison, and are reported as measured.

Choices, stated once:

- **115 bytes.** ``px4_msgs`` ``VehicleOdometry`` is 118 bytes in CDR and ``SensorCombined``
  52; we keep the real message types (the FCU parses and fuses the vision sample like any
  other) and make the link *charge* 115 bytes for them: :class:`ChargedSizeLink` replaces
  the size given to :meth:`~sim.fcu.link.Link.send` for ``(direction, CDR size)`` pairs.
  The two sizes are unique in their directions among the FCU's topics (checked by
  :func:`stream_charges`), so no other message is affected. Seed 000 did the same the other
  way round: it custom-modified its messages to carry 115 bytes.
- **Firmware rates.** 200 Hz is not a whole number of 500 Hz main-loop ticks, so the
  experiment runs the firmware's main loop at :data:`MAIN_LOOP_HZ` (1 kHz) with
  ``pub_sensor_combined`` at 200 Hz, ``imu_update`` every tick (the IMU stamp is the tick
  that publishes it) and the FCU's other telemetry at 1 Hz: seed 000 ran its bridges with
  only the test topics (section 3.3), and the serial line is FIFO, so full telemetry would
  queue the IMU stream (about +200 us here). All in :data:`EXPERIMENT_RATES_HZ`.
- **Forward consumption: event-driven.** In flight the FCU takes companion messages in its
  500 Hz ``dds_receive`` poll. Table 3 leaves no room for that wait: at the seed's 921600
  baud (8N1, section 2.1) the 115 bytes alone take 1247.8 us, all but 81 us of the forward
  mean, and a poll of period P adds P/2 to the mean and P/sqrt(12) to the spread (500 Hz:
  +1000 us and 577 us, over three times Table 3's forward standard deviation), whatever
  the baud rate; the stream's 5 ms period, a whole number of ticks, even makes every
  forward latency a whole 2 or 3 ms. :meth:`~sim.fcu.link.AddedDelay.poll` and
  :func:`~sim.fcu.link.calibrate_direction` say so. Seed 000's firmware was modified for
  exactly this: "a complete event-driven MicroXRCE-DDS - ROS 2 bridge, which allows
  incoming and outgoing messages to be consumed by requesting processes as soon as they
  are available" (section 4.3). So the experiment's firmware hands the vision stream to its
  estimator the moment it arrives (:data:`EVENT_DRIVEN_INPUTS`); the other inputs, time
  sync included, keep the 500 Hz poll they have in flight. The forward latency is still
  taken where the estimator parses the sample.
- **End-to-end calibration.** The line is FIFO, so the streams also queue behind the
  time-sync messages (forward about +15 us mean, reverse about +60 us and a wider
  spread). :func:`fit_link` runs the experiment, measures what the path adds to the idle
  link on the true clock (:meth:`~sim.fcu.link.AddedDelay.measured`), and solves the
  link's gamma jitter again with :func:`~sim.fcu.link.calibrate_direction` so that the
  end-to-end figures are Table 3's; ``config/fcu_link.yaml`` holds the result
  (``quadmission latency --fit`` refits it). The corrected figures differ from the
  true-clock ones by the estimator's offset error.
- **Time-sync exchanges** at :data:`DEFAULT_TIMESYNC_HZ` (97 Hz, 10.31 ms): a period that
  is not a whole number of FCU ticks, so exchanges meet the FCU's poll at every phase, as
  between free-running clocks. At exactly 100 Hz every request would wait the same part of
  the poll cycle, and both estimators would see an unrepresentative path asymmetry.
- **Measurement window.** Only samples created (forward) or received (reverse) after
  every estimator has converged count (seed 000: "after convergence is reached").
- **Offset error.** Each estimate after an exchange against the simulator's true offset
  at that local time (``companion - FCU``, from the link's :class:`~sim.fcu.clock.FcuClock`):
  ``estimate - true``. ``p50``/``p99``/``max`` are of its magnitude, ``bias`` its mean.
  Ground truth enters only here, in evaluation; the node never sees it.

The statistics (:func:`analyse`) are pure; :func:`run_latency_experiment` assembles the SITL
(MuJoCo, imported when called).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from enum import Enum
from types import MappingProxyType
from typing import Any

import numpy as np

from flight_control.latency_node import LatencyTestNode, OffsetLog, ReceivedImu, SentVision
from interfaces.px4.seed000 import (
    TABLE3_MESSAGE_SIZE_BYTES,
    TABLE3_TO_COMPANION,
    TABLE3_TO_FCU,
    LatencyFigure,
)
from quadmission.errors import ExperimentError
from runtime.parameters import load_parameters
from sim.fcu.link import (
    LINK_NODE_NAME,
    AddedDelay,
    Link,
    LinkDirection,
    LinkDirectionParams,
    LinkParams,
    calibrate_direction,
)

__all__ = [
    "DEFAULT_TIMESYNC_HZ",
    "ESTIMATOR_NAMES",
    "EVENT_DRIVEN_INPUTS",
    "EXPERIMENT_RATES_HZ",
    "MAIN_LOOP_HZ",
    "STREAM_RATE_HZ",
    "TABLE3",
    "ChargedSizeLink",
    "LatencyConfig",
    "LatencyPath",
    "LatencyReport",
    "LatencyStats",
    "LinkFit",
    "OffsetErrorBin",
    "OffsetErrorStats",
    "OffsetLog",
    "PathFigures",
    "ReceivedImu",
    "SentVision",
    "analyse",
    "fit_link",
    "format_fit",
    "format_report",
    "run_latency_experiment",
    "stream_charges",
]

STREAM_RATE_HZ = 200.0
"""Rate of both streams (seed 000 Tables 1-2) [Hz]."""
MAIN_LOOP_HZ = 1000
"""The firmware's main loop in the experiment [Hz]: a multiple of 200 Hz and 500 Hz."""
PHYSICS_HZ = 3000
"""The experiment's physics rate [Hz]: the 1 kHz main loop must divide it (the world's
default, 1.5 kHz, is the lowest for the flight scenarios' 500 Hz loop)."""
QUIET_TELEMETRY_HZ = 1.0
"""Rate of the FCU's other /fmu/out telemetry during the experiment [Hz]."""
EXPERIMENT_RATES_HZ: Mapping[str, float] = MappingProxyType({
    "pub_sensor_combined": STREAM_RATE_HZ,
    "imu_update": float(MAIN_LOOP_HZ),
    **{f"pub_{topic}": QUIET_TELEMETRY_HZ for topic in (
        "vehicle_odometry", "vehicle_local_position", "vehicle_attitude", "vehicle_status",
        "battery_status", "timesync_status", "vehicle_land_detected", "failsafe_flags")},
})
"""Firmware periodic-function rates the experiment overrides [Hz]."""
EVENT_DRIVEN_INPUTS: frozenset[str] = frozenset({"vehicle_visual_odometry"})
"""/fmu/in topics the experiment's firmware consumes on arrival (seed 000 section 4.3)."""
DEFAULT_TIMESYNC_HZ = 97.0
"""Timesync exchanges per second [Hz]: not a multiple of the FCU tick (see above); PX4's
filter converges (500 samples) in about 5 s."""
ESTIMATOR_NAMES: tuple[str, ...] = ("px4", "kalman")
"""The estimators run side by side (:data:`flight_control.timesync.ESTIMATORS`)."""


class LatencyPath(Enum):
    """The two directions of seed 000's test."""

    FORWARD = "forward"  # companion -> FCU, vision, measured at the FCU's estimator
    REVERSE = "reverse"  # FCU -> companion, IMU, measured at the companion node


TABLE3: Mapping[LatencyPath, LatencyFigure] = MappingProxyType(
    {LatencyPath.FORWARD: TABLE3_TO_FCU, LatencyPath.REVERSE: TABLE3_TO_COMPANION})
"""Seed 000 Table 3, MicroXRCE-DDS - ROS 2 (mean +/- sd) [us]."""


# -- figures ----------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class LatencyStats:
    """One-way latency figures [us] over ``n`` samples (nan when there are none)."""

    mean_us: float
    sd_us: float
    p50_us: float
    p99_us: float
    max_us: float
    n: int

    @classmethod
    def of(cls, samples_us: Sequence[float] | np.ndarray) -> LatencyStats:
        x = np.asarray(samples_us, dtype=np.float64)
        if x.size == 0:
            return cls(math.nan, math.nan, math.nan, math.nan, math.nan, 0)
        return cls(float(x.mean()), float(x.std(ddof=1)) if x.size > 1 else 0.0,
                   float(np.percentile(x, 50)), float(np.percentile(x, 99)), float(x.max()),
                   int(x.size))

    def to_json(self) -> dict[str, float | int]:
        return {"mean_us": round(self.mean_us, 1), "sd_us": round(self.sd_us, 1),
                "p50_us": round(self.p50_us, 1), "p99_us": round(self.p99_us, 1),
                "max_us": round(self.max_us, 1), "n": self.n}


@dataclass(frozen=True, slots=True)
class PathFigures:
    """One path: the raw-stamp figures and the figures corrected by each estimator."""

    uncorrected: LatencyStats
    corrected: Mapping[str, LatencyStats]
    true: LatencyStats  # with the simulator's true clock offset (evaluation only)


@dataclass(frozen=True, slots=True)
class OffsetErrorStats:
    """``estimate - true`` offset after convergence [us]: quantiles of its magnitude, mean."""

    p50: float
    p99: float
    max: float
    bias: float
    n: int

    @classmethod
    def of(cls, errors_us: Sequence[float] | np.ndarray) -> OffsetErrorStats:
        e = np.asarray(errors_us, dtype=np.float64)
        if e.size == 0:
            return cls(math.nan, math.nan, math.nan, math.nan, 0)
        a = np.abs(e)
        return cls(float(np.percentile(a, 50)), float(np.percentile(a, 99)), float(a.max()),
                   float(e.mean()), int(e.size))

    def to_json(self) -> dict[str, float | int]:
        return {"p50": round(self.p50, 1), "p99": round(self.p99, 1), "max": round(self.max, 1),
                "bias": round(self.bias, 1), "n": self.n}


@dataclass(frozen=True, slots=True)
class OffsetErrorBin:
    """Median ``estimate - true`` offset [us] per estimator over ``[start_s, end_s)``."""

    start_s: float
    end_s: float
    median_error_us: Mapping[str, float]


@dataclass(frozen=True)
class LatencyReport:
    """Everything the experiment measured (see the module docstring for the definitions)."""

    duration_s: float
    seed: int
    primary: str  # the estimator whose figures are the top-level ``corrected`` ones
    window_start_s: float  # local time from which samples count (all estimators converged)
    converged_s: Mapping[str, float]  # local time each estimator first converged
    forward: PathFigures
    reverse: PathFigures
    offset_error: Mapping[str, OffsetErrorStats]
    offset_error_over_time: tuple[OffsetErrorBin, ...]
    forward_sent: int  # forward samples created in the window (some are lost on the link)
    charged_messages: Mapping[str, int]  # messages the link charged 115 bytes, per direction
    rate_hz: float = STREAM_RATE_HZ
    timesync_hz: float = DEFAULT_TIMESYNC_HZ
    payload_bytes: int = TABLE3_MESSAGE_SIZE_BYTES

    def path(self, path: LatencyPath) -> PathFigures:
        return self.forward if path is LatencyPath.FORWARD else self.reverse

    def to_json(self) -> dict[str, Any]:
        """The report as JSON: top-level ``forward``/``reverse``/``offset_error_us`` are the
        ``primary`` estimator's; ``estimators`` holds the same for each estimator."""

        def path_json(path: LatencyPath, name: str) -> dict[str, Any]:
            figures = self.path(path)
            return {"corrected": figures.corrected[name].to_json(),
                    "uncorrected": figures.uncorrected.to_json(),
                    "true_clock": figures.true.to_json()}

        def table3(path: LatencyPath) -> dict[str, Any]:
            paper = TABLE3[path]
            measured = self.path(path).corrected[self.primary]
            return {"mean_us": paper.mean_us, "sd_us": paper.sd_us,
                    "ratio_mean": round(measured.mean_us / paper.mean_us, 4),
                    "ratio_sd": round(measured.sd_us / paper.sd_us, 4)}

        names = list(self.offset_error)
        return {
            "duration_s": self.duration_s,
            "seed": self.seed,
            "payload_bytes": self.payload_bytes,
            "rate_hz": self.rate_hz,
            "timesync_hz": self.timesync_hz,
            "main_loop_hz": MAIN_LOOP_HZ,
            "estimator": self.primary,
            "window_start_s": round(self.window_start_s, 3),
            "converged_s": {k: round(v, 3) for k, v in self.converged_s.items()},
            "forward": path_json(LatencyPath.FORWARD, self.primary),
            "reverse": path_json(LatencyPath.REVERSE, self.primary),
            "offset_error_us": self.offset_error[self.primary].to_json(),
            "estimators": {
                name: {"forward": path_json(LatencyPath.FORWARD, name),
                       "reverse": path_json(LatencyPath.REVERSE, name),
                       "offset_error_us": self.offset_error[name].to_json()}
                for name in names
            },
            "offset_error_over_time_us": [
                {"start_s": b.start_s, "end_s": b.end_s,
                 **{k: None if math.isnan(v) else round(v, 1)
                    for k, v in b.median_error_us.items()}}
                for b in self.offset_error_over_time
            ],
            "table3_us": {"forward": table3(LatencyPath.FORWARD),
                          "reverse": table3(LatencyPath.REVERSE)},
            "forward_sent": self.forward_sent,
            "charged_messages": dict(self.charged_messages),
            "event_driven_inputs": sorted(EVENT_DRIVEN_INPUTS),
        }


# -- analysis (pure) --------------------------------------------------------------------------
def analyse(
    *,
    sent: Mapping[int, SentVision],
    consumed: Sequence[tuple[int, int]],
    received: Sequence[ReceivedImu],
    offsets: Sequence[OffsetLog],
    converged_us: Mapping[str, int | None],
    true_offset_us: Callable[[int], int],
    true_fcu_us: Callable[[int], int],
    true_local_us: Callable[[int], int],
    duration_s: float,
    seed: int,
    primary: str,
    charged_messages: Mapping[str, int] | None = None,
    timesync_hz: float = DEFAULT_TIMESYNC_HZ,
    bin_s: float | None = None,
) -> LatencyReport:
    """Figures from the logs of one run.

    ``consumed`` holds ``(timestamp_us, consumed_fcu_us)`` of each vision sample the FCU's
    estimator took (``timestamp`` is the companion's creation time, the key into ``sent``);
    ``true_offset_us(t_us)`` is the true ``companion - FCU`` offset at local time ``t_us``,
    ``true_fcu_us(t_us)`` the FCU clock at local time ``t_us`` and ``true_local_us(fcu_us)``
    the local time at which the FCU clock read ``fcu_us``.
    Raises ExperimentError when an estimator never converged (run longer).
    """
    names = list(converged_us)
    if primary not in names:
        raise ValueError(f"primary estimator {primary!r} is not one of {names}")
    missing = [name for name, t in converged_us.items() if t is None]
    if missing:
        raise ExperimentError(
            f"estimator(s) {missing} never converged in {duration_s:g} s: run longer")
    start_us = max(t for t in converged_us.values() if t is not None)

    window = [s for s in sent.values() if s.created_us >= start_us]
    fwd_raw: list[int] = []
    fwd_true: list[int] = []
    fwd: dict[str, list[int]] = {name: [] for name in names}
    for key, consumed_us in consumed:
        sample = sent.get(key)
        if sample is None or sample.created_us < start_us:
            continue
        fwd_raw.append(consumed_us - sample.created_us)
        fwd_true.append(consumed_us - true_fcu_us(sample.created_us))
        for name in names:
            fwd[name].append(consumed_us - sample.fcu_stamp_us[name])
    rev = [r for r in received if r.received_us >= start_us]
    forward = PathFigures(LatencyStats.of(fwd_raw),
                          {name: LatencyStats.of(fwd[name]) for name in names},
                          LatencyStats.of(fwd_true))
    reverse = PathFigures(
        LatencyStats.of([r.received_us - r.stamp_us for r in rev]),
        {name: LatencyStats.of([r.received_us - r.local_stamp_us[name] for r in rev])
         for name in names},
        LatencyStats.of([r.received_us - true_local_us(r.stamp_us) for r in rev]))

    t = np.array([o.t_us for o in offsets], dtype=np.int64)
    truth = np.array([true_offset_us(int(ti)) for ti in t], dtype=np.float64)
    errors = {name: np.array([o.offset_us[name] for o in offsets], dtype=np.float64) - truth
              for name in names}
    after = t >= start_us
    offset_error = {name: OffsetErrorStats.of(errors[name][after]) for name in names}

    width = bin_s or max(1.0, duration_s / 12.0)
    bins = []
    for i in range(math.ceil(duration_s / width - 1e-9)):
        lo, hi = i * width, min((i + 1) * width, duration_s)
        inside = (t >= lo * 1e6) & (t < hi * 1e6)
        bins.append(OffsetErrorBin(round(lo, 3), round(hi, 3), {
            name: float(np.median(errors[name][inside])) if inside.any() else math.nan
            for name in names}))

    return LatencyReport(
        duration_s=duration_s, seed=seed, primary=primary, window_start_s=start_us / 1e6,
        converged_s={name: (t_us or 0) / 1e6 for name, t_us in converged_us.items()},
        forward=forward, reverse=reverse, offset_error=offset_error,
        offset_error_over_time=tuple(bins), forward_sent=len(window),
        charged_messages=dict(charged_messages or {}), timesync_hz=timesync_hz)


def _fmt_stats(s: LatencyStats) -> str:
    return (f"{s.mean_us:>12.0f} +/- {s.sd_us:<7.0f}{s.p50_us:>12.0f}{s.p99_us:>12.0f}"
            f"{s.max_us:>12.0f}{s.n:>7}")


def format_report(report: LatencyReport) -> str:
    """The report as text: Table 3's layout plus quantiles, then the offset error."""
    names = list(report.offset_error)
    lines = [
        f"Seed 000 latency test: {report.payload_bytes}-byte payloads at "
        f"{report.rate_hz:g} Hz, {report.duration_s:g} s simulated, seed {report.seed}; "
        f"timesync {report.timesync_hz:g} Hz, FCU main loop {MAIN_LOOP_HZ} Hz",
        f"samples counted from t = {report.window_start_s:.2f} s (all estimators converged: "
        + ", ".join(f"{k} {v:.2f} s" for k, v in report.converged_s.items()) + ")",
        "",
        f"{'path':<30}{'time sync':<11}{'mean +/- sd (us)':>23}{'p50':>12}{'p99':>12}"
        f"{'max':>12}{'n':>7}   Table 3",
    ]
    titles = {LatencyPath.FORWARD: ("Companion -> FCU", "vision, at FCU estimator"),
              LatencyPath.REVERSE: ("FCU -> Companion", "IMU, at companion node")}
    for path in LatencyPath:
        figures = report.path(path)
        paper = TABLE3[path]
        title, what = titles[path]
        rows = [("none", figures.uncorrected), *((n, figures.corrected[n]) for n in names),
                ("true", figures.true)]
        for i, (label, stats) in enumerate(rows):
            left = title if i == 0 else (f"  ({what})" if i == 1 else "")
            tail = f"   {paper.mean_us:.0f} +/- {paper.sd_us:.0f}" if i == 1 else ""
            lines.append(f"{left:<30}{label:<11}{_fmt_stats(stats)}{tail}")
    lines.append("(forward: the FCU's estimator takes the sample on arrival, as seed 000's "
                 "event-driven bridge; 'none': raw stamps, with the clock offset; 'true': the "
                 "simulator's true offset)")
    lines += ["", "Offset error after convergence, |estimate - true| (us):",
              f"  {'estimator':<10}{'p50':>9}{'p99':>9}{'max':>9}{'bias':>9}{'n':>7}"]
    for name in names:
        e = report.offset_error[name]
        lines.append(f"  {name:<10}{e.p50:>9.1f}{e.p99:>9.1f}{e.max:>9.1f}{e.bias:>9.1f}{e.n:>7}")
    lines += ["", "Offset error over time, median of estimate - true (us):",
              f"  {'t (s)':<14}" + "".join(f"{n:>14}" for n in names)]
    for b in report.offset_error_over_time:
        cells = "".join(f"{b.median_error_us[n]:>14.1f}" for n in names)
        lines.append(f"  {f'{b.start_s:g}-{b.end_s:g}':<14}{cells}")
    return "\n".join(lines)


# -- the experiment -----------------------------------------------------------------------------
class ChargedSizeLink(Link):
    """A :class:`~sim.fcu.link.Link` that charges some messages another size on the wire.

    ``charges`` maps ``(direction, CDR size)`` to the size the line is charged instead
    (wire time and everything else as :class:`Link`); :attr:`charged` counts them.
    """

    def __init__(self, params: LinkParams,
                 charges: Mapping[tuple[LinkDirection, int], int]) -> None:
        super().__init__(params)
        self.charges = dict(charges)
        self.charged = dict.fromkeys(self.charges, 0)

    def send(self, direction: LinkDirection, send_time_ns: int, size_bytes: int) -> int | None:
        key = (direction, size_bytes)
        if key in self.charges:
            self.charged[key] += 1
            size_bytes = self.charges[key]
        return super().send(direction, send_time_ns, size_bytes)


def stream_charges() -> dict[tuple[LinkDirection, int], int]:
    """``(direction, CDR size) -> 115`` for the two streams' message types, after checking
    that no other message crossing that direction has the same CDR size."""
    import interfaces
    from interfaces.px4.topics import XRCE_TIMESYNC_BYTES
    from sim.fcu.agent import AGENT_IN, AGENT_OUT

    def size(type_name: str) -> int:
        return len(interfaces.serialize(interfaces.new(type_name), type_name))

    streams = {LinkDirection.TO_FCU: ("vehicle_visual_odometry", AGENT_IN),
               LinkDirection.TO_COMPANION: ("sensor_combined", AGENT_OUT)}
    charges = {}
    for direction, (topic, topics) in streams.items():
        own = size(topics[topic].type)
        others = {size(t.type) for name, t in topics.items() if name != topic}
        if own in others | {XRCE_TIMESYNC_BYTES}:
            raise ValueError(f"{direction.value}: {topic} ({own} B) is not the only message "
                             f"of its CDR size; the link cannot charge it alone")
        charges[(direction, own)] = TABLE3_MESSAGE_SIZE_BYTES
    return charges


@dataclass(frozen=True)
class LatencyConfig:
    """One run of the experiment."""

    duration_s: float = 60.0  # simulated [s]
    seed: int = 0
    primary: str = "kalman"  # estimator whose corrected figures are the top-level ones
    timesync_hz: float = DEFAULT_TIMESYNC_HZ  # [Hz]

    def __post_init__(self) -> None:
        if not self.duration_s > 0:
            raise ValueError(f"duration_s={self.duration_s}: must be > 0")
        if self.primary not in ESTIMATOR_NAMES:
            raise ValueError(f"primary={self.primary!r}: choose one of {list(ESTIMATOR_NAMES)}")
        if not self.timesync_hz > 0:
            raise ValueError(f"timesync_hz={self.timesync_hz}: must be > 0")


def run_latency_experiment(config: LatencyConfig | None = None,
                           link: LinkParams | None = None) -> LatencyReport:
    """Run seed 000's test in the SITL (vehicle on the pad, disarmed) and analyse it;
    ``link`` replaces the parameters of ``config/fcu_link.yaml``."""
    from sim.fcu.firmware import ConsumedVision, FirmwareConfig
    from sim.fcu.sitl import build_sitl

    cfg = config or LatencyConfig()
    sitl = build_sitl(seed=cfg.seed, link=link, physics_hz=PHYSICS_HZ, firmware=FirmwareConfig(
        main_freq_hz=MAIN_LOOP_HZ, rates_hz=EXPERIMENT_RATES_HZ,
        event_driven_inputs=EVENT_DRIVEN_INPUTS))
    charged = ChargedSizeLink(sitl.link.params, stream_charges())  # nothing sent: same draws
    sitl.link = charged
    sitl.agent.link = charged
    consumed: list[tuple[int, int]] = []

    def on_vision(sample: ConsumedVision) -> None:
        consumed.append((sample.timestamp_us, sample.consumed_us))

    sitl.firmware.vision_observers.append(on_vision)
    node = LatencyTestNode(rate_hz=STREAM_RATE_HZ, timesync_hz=cfg.timesync_hz,
                           estimators=ESTIMATOR_NAMES, primary=cfg.primary,
                           context=sitl.executor.context)
    sitl.executor.add_node(node)
    sitl.run(cfg.duration_s)
    clock = charged.clock

    def true_fcu_us(t_us: int) -> int:  # the companion's clock is simulated time
        return clock.fcu_time_us(t_us * 1000)

    def true_local_us(fcu_us: int) -> int:
        return clock.sim_time_ns(fcu_us) // 1000

    def true_offset_us(t_us: int) -> int:
        return t_us - true_fcu_us(t_us)

    return analyse(
        sent=node.sent, consumed=consumed, received=node.received, offsets=node.offsets,
        converged_us=node.converged_us, true_offset_us=true_offset_us,
        true_fcu_us=true_fcu_us, true_local_us=true_local_us,
        duration_s=cfg.duration_s, seed=cfg.seed, primary=cfg.primary,
        charged_messages={d.value: n for (d, _), n in charged.charged.items()},
        timesync_hz=cfg.timesync_hz)


# -- fitting the link to Table 3, end to end ----------------------------------------------------
_LINK_DIRECTION = {LatencyPath.FORWARD: LinkDirection.TO_FCU,
                   LatencyPath.REVERSE: LinkDirection.TO_COMPANION}


def _pooled(stats: Sequence[LatencyStats]) -> LatencyFigure:
    """Mean and standard deviation of the union of the samples behind ``stats``."""
    n = sum(s.n for s in stats)
    if n == 0:
        raise ExperimentError("no samples to pool: run longer")
    mean = sum(s.n * s.mean_us for s in stats) / n
    var = sum(s.n * (s.sd_us**2 + (s.mean_us - mean) ** 2) for s in stats) / n
    return LatencyFigure(mean, math.sqrt(var))


@dataclass(frozen=True)
class LinkFit:
    """The link fitted by :func:`fit_link` and what the experiment measured with it."""

    params: LinkParams
    measured: Mapping[LatencyPath, LatencyFigure]  # true clock, pooled over the seeds [us]
    added: Mapping[LatencyPath, AddedDelay]  # what the path adds to the fitted idle link


def fit_link(
    link: LinkParams | None = None,
    *,
    seeds: Sequence[int] = (0, 1, 2),
    duration_s: float = 60.0,
    iterations: int = 2,
) -> LinkFit:
    """Fit the link's gamma jitter so that the experiment's true-clock latencies are Table 3's.

    Each iteration runs the experiment for every seed with the current parameters, pools
    the true-clock figures, takes what the path added to the idle link's moments
    (:meth:`AddedDelay.measured`: FIFO queueing behind the other messages) and re-solves
    each direction with :func:`calibrate_direction`. The floor, spikes, loss and line
    settings are kept. The result is measured once more with the fitted parameters.
    Raises FcuParameterError when a direction cannot reach its figure (see
    :func:`calibrate_direction`).
    """
    if iterations < 1:
        raise ExperimentError(f"iterations={iterations}: must be >= 1")
    if not seeds:
        raise ExperimentError("seeds: give at least one")
    params = link or load_parameters(LinkParams, LINK_NODE_NAME)

    def measure(p: LinkParams) -> dict[LatencyPath, LatencyFigure]:
        reports = [run_latency_experiment(LatencyConfig(duration_s=duration_s, seed=seed), p)
                   for seed in seeds]
        return {path: _pooled([r.path(path).true for r in reports]) for path in LatencyPath}

    def added(p: LinkParams, path: LatencyPath) -> AddedDelay:
        return AddedDelay.measured(measured[path], p.direction(_LINK_DIRECTION[path]))

    def refit(p: LinkParams, path: LatencyPath) -> LinkDirectionParams:
        return calibrate_direction(TABLE3[path], p.direction(_LINK_DIRECTION[path]),
                                   added=added(p, path))

    measured = measure(params)
    for _ in range(iterations):
        params = replace(params, to_fcu=refit(params, LatencyPath.FORWARD),
                         to_companion=refit(params, LatencyPath.REVERSE))
        measured = measure(params)
    return LinkFit(params, measured, {path: added(params, path) for path in LatencyPath})


def format_fit(fit: LinkFit, seeds: Sequence[int], duration_s: float) -> str:
    """The fitted jitter as ``config/fcu_link.yaml`` lines, with what it achieves."""
    lines = [f"# fitted end to end: seeds {list(seeds)}, {duration_s:g} s each, true clock"]
    for path in LatencyPath:
        name, paper, got = _LINK_DIRECTION[path].value, TABLE3[path], fit.measured[path]
        direction = fit.params.direction(_LINK_DIRECTION[path])
        added = fit.added[path]
        lines += [
            f"# {path.value}: {got.mean_us:.1f} +/- {got.sd_us:.1f} us "
            f"(Table 3: {paper.mean_us:g} +/- {paper.sd_us:g}); the path adds "
            f"{added.mean_us:+.1f} us mean, {added.variance_us2:+.0f} us^2 variance",
            f"{name}:",
            f"  jitter_shape: {direction.jitter_shape:.4f}",
            f"  jitter_scale_us: {direction.jitter_scale_us:.2f}",
        ]
    return "\n".join(lines)
