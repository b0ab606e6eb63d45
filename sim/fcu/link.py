"""The serial link between the companion computer and the simulated FCU.

Each direction (:class:`LinkDirection`) delays every message by, in simulated time::

    latency = base_latency_us                       fixed processing floor
            + Gamma(jitter_shape, jitter_scale_us)   scheduling / processing jitter
            + spike                                  load spike, see below
            + wire time                              bytes on the line / baud rate

    spike     = U(spike_min_us, spike_max_us) with spike_probability, else 0
    wire time = (cdr_size + framing_overhead_bytes) * bits_per_byte / baud_rate

and loses it with ``loss_probability`` (lost messages never reach the line). The line is a
FIFO, like a UART: a message cannot overtake an earlier one in the same direction, and
it is delivered no earlier than the previous delivery plus its own wire time::

    delivery_ns = max(send_ns + latency_ns, previous_delivery_ns + wire_time_ns)

Every message draws the same random numbers (three uniforms and one gamma) from its
direction's own ``numpy.random.Generator``, whether it is lost, spiked or neither, so
the same seed and the same sends give the same deliveries, and the two directions do
not disturb each other.

Calibration (seed 000, Table 3, MicroXRCE-DDS - ROS 2 row): a 115-byte message takes
1329 +/- 162 us companion -> FCU and 1752 +/- 315 us FCU -> companion (mean +/- standard
deviation, end to end). The table gives two moments, so the shape is a choice: a
floor plus a gamma tail (as OS and serial-link latency looks) plus rare load spikes
(the latency peaks of the seed's Figure 8). :func:`calibrate_direction` keeps the floor,
the spikes and the line settings and solves the gamma's shape and scale so that the
mean and the standard deviation at the reference size are the table's exactly; the
defaults in ``config/fcu_link.yaml`` were fitted that way. At 921 600 baud, 8N1, the
wire time of 115 bytes alone is 1247.8 us, which leaves only 81 us of mean for
everything else companion -> FCU: that direction has no floor, no framing overhead
and a strongly skewed gamma (shape < 1).

Pure module: numpy and PyYAML, no runtime, no MuJoCo.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from interfaces.px4.seed000 import (
    TABLE3_MESSAGE_SIZE_BYTES,
    TABLE3_TO_COMPANION,
    TABLE3_TO_FCU,
    LatencyFigure,
)
from runtime.errors import ParameterError
from runtime.parameters import param, validate_parameters
from sim.errors import SimError
from sim.fcu.clock import FcuClock

__all__ = [
    "LINK_NODE_NAME",
    "TABLE3_MESSAGE_SIZE_BYTES",
    "TABLE3_TO_COMPANION",
    "TABLE3_TO_FCU",
    "LatencyFigure",
    "Link",
    "LinkCounters",
    "LinkDirection",
    "LinkDirectionParams",
    "LinkOrderError",
    "LinkParams",
    "calibrate_direction",
]

LINK_NODE_NAME = "fcu_link"
"""The link's section in its ROS 2 parameter file, ``config/fcu_link.yaml``."""

_NS_PER_S = 1_000_000_000
_NS_PER_US = 1000


class LinkDirection(Enum):
    """Which way a message travels; the value is its key in the YAML."""

    TO_FCU = "to_fcu"
    TO_COMPANION = "to_companion"


class LinkOrderError(SimError, ValueError):
    """A message handed to the link earlier than the previous one in the same direction."""


# -- parameters ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class LinkDirectionParams:
    """Latency, spikes, loss and line settings of one direction (see the module docstring)."""

    base_latency_us: float = param(unit="us", range=(0.0, 1e6))
    """Fixed latency floor on top of the wire time [us]."""
    jitter_shape: float = param(range=(1e-3, 1e3))
    """Shape k of the gamma jitter (skewness 2/sqrt(k); large k looks Gaussian)."""
    jitter_scale_us: float = param(unit="us", range=(0.0, 1e6))
    """Scale theta of the gamma jitter [us]: mean k*theta, variance k*theta^2."""
    spike_probability: float = param(range=(0.0, 1.0))
    """Chance that a message gets a load spike on top of its latency."""
    spike_min_us: float = param(unit="us", range=(0.0, 1e7))
    """Smallest extra latency of a spike [us]."""
    spike_max_us: float = param(unit="us", range=(0.0, 1e7))
    """Largest extra latency of a spike [us], >= spike_min_us; uniform in between."""
    loss_probability: float = param(range=(0.0, 1.0))
    """Chance that a message is lost (never delivered)."""
    baud_rate: int = param(unit="bit/s", range=(300, 100_000_000))
    """Line rate [bit/s] (symbols per second of the UART)."""
    bits_per_byte: int = param(unit="bit", range=(0, 12))
    """Bits on the line per byte: 10 for 8N1 (start + 8 data + stop); 0 is an ideal line."""
    framing_overhead_bytes: int = param(unit="bytes", range=(0, 65_535))
    """Bytes added to each message's CDR size by the transport's framing and headers."""

    def __post_init__(self) -> None:
        validate_parameters(self)
        if self.spike_max_us < self.spike_min_us:
            raise ParameterError(
                f"{self.spike_max_us!r} is outside the allowed range "
                f"[spike_min_us = {self.spike_min_us!r}, 1e+07] us",
                key="spike_max_us",
            )

    def wire_time_ns(self, size_bytes: int) -> int:
        """Time [ns, rounded up] to clock ``size_bytes`` of CDR plus the framing onto the line."""
        bits = (size_bytes + self.framing_overhead_bytes) * self.bits_per_byte
        return -((-bits * _NS_PER_S) // self.baud_rate)

    @property
    def spike_mean_us(self) -> float:
        """Mean extra latency of a spike [us]."""
        return 0.5 * (self.spike_min_us + self.spike_max_us)

    def mean_latency_us(self, size_bytes: int) -> float:
        """Expected one-way latency [us] of a ``size_bytes`` message on an idle line."""
        return (
            self.base_latency_us
            + self.jitter_shape * self.jitter_scale_us
            + self.spike_probability * self.spike_mean_us
            + self.wire_time_ns(size_bytes) / _NS_PER_US
        )

    def latency_sd_us(self) -> float:
        """Standard deviation of the one-way latency [us] on an idle line (any size)."""
        return math.sqrt(self.jitter_shape * self.jitter_scale_us**2 + _spike_variance_us2(self))

    @classmethod
    def null(cls) -> LinkDirectionParams:
        """An ideal direction: no latency, no jitter, no spikes, no loss, no wire time."""
        return cls(
            base_latency_us=0.0,
            jitter_shape=1.0,
            jitter_scale_us=0.0,
            spike_probability=0.0,
            spike_min_us=0.0,
            spike_max_us=0.0,
            loss_probability=0.0,
            baud_rate=921_600,
            bits_per_byte=0,
            framing_overhead_bytes=0,
        )


def _spike_variance_us2(params: LinkDirectionParams) -> float:
    """Variance [us^2] of the spike term: Bernoulli(p) times Uniform(a, b)."""
    p, a, b = params.spike_probability, params.spike_min_us, params.spike_max_us
    second_moment = (a * a + a * b + b * b) / 3.0
    return p * second_moment - (p * params.spike_mean_us) ** 2


def calibrate_direction(
    target: LatencyFigure,
    template: LinkDirectionParams,
    size_bytes: int = TABLE3_MESSAGE_SIZE_BYTES,
) -> LinkDirectionParams:
    """``template`` with the gamma jitter solved so that ``size_bytes`` messages have
    ``target``'s mean and standard deviation (on an idle line).

    The floor, spikes, loss and line settings of ``template`` are kept; with
    ``m = mean - floor - wire time - p * spike mean`` and ``v = sd^2 - spike variance``
    the gamma has shape ``m^2 / v`` and scale ``v / m``. Raises ParameterError when
    the template leaves no positive mean or variance for the jitter.
    """
    wire_us = template.wire_time_ns(size_bytes) / _NS_PER_US
    jitter_mean_us = (
        target.mean_us
        - template.base_latency_us
        - wire_us
        - template.spike_probability * template.spike_mean_us
    )
    jitter_var_us2 = target.sd_us**2 - _spike_variance_us2(template)
    if jitter_mean_us <= 0.0:
        raise ParameterError(
            f"floor {template.base_latency_us:g} us + wire time {wire_us:.1f} us + mean spike "
            f"{template.spike_probability * template.spike_mean_us:.1f} us leave no room "
            f"under the target mean {target.mean_us:g} us",
            key="base_latency_us",
        )
    if jitter_var_us2 <= 0.0:
        raise ParameterError(
            f"the spikes alone have a standard deviation of "
            f"{math.sqrt(_spike_variance_us2(template)):.1f} us, not below the target "
            f"{target.sd_us:g} us",
            key="spike_probability",
        )
    return replace(
        template,
        jitter_shape=jitter_mean_us**2 / jitter_var_us2,
        jitter_scale_us=jitter_var_us2 / jitter_mean_us,
    )


@dataclass(frozen=True, slots=True)
class LinkParams:
    """Both directions, the seed of their random streams, and the FCU clock."""

    to_fcu: LinkDirectionParams
    """Companion computer -> flight controller (``/fmu/in/*``)."""
    to_companion: LinkDirectionParams
    """Flight controller -> companion computer (``/fmu/out/*``)."""
    seed: int = param(range=(0, 2**63 - 1))
    """Seed of the per-direction random generators."""
    clock: FcuClock = field(default_factory=FcuClock.ideal)
    """The FCU's clock against simulated time."""

    def __post_init__(self) -> None:
        validate_parameters(self)

    def direction(self, direction: LinkDirection) -> LinkDirectionParams:
        """The parameters of one direction."""
        return self.to_fcu if direction is LinkDirection.TO_FCU else self.to_companion

    @classmethod
    def null(cls, seed: int = 0) -> LinkParams:
        """An ideal link (delivery at the send time, nothing lost) and an ideal clock."""
        ideal = LinkDirectionParams.null()
        return cls(to_fcu=ideal, to_companion=ideal, seed=seed, clock=FcuClock.ideal())


# -- the link ------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class LinkCounters:
    """What one direction has done so far."""

    sent: int
    """Messages handed to :meth:`Link.send`."""
    lost: int
    """Messages lost (``send`` returned None)."""
    spikes: int
    """Delivered messages that got a load spike."""

    @property
    def delivered(self) -> int:
        return self.sent - self.lost


_NEVER_NS = -(2**63)  # before any send or delivery


class _DirectionState:
    """Random stream, FIFO state and counters of one direction."""

    __slots__ = ("last_delivery_ns", "last_send_ns", "lost", "params", "rng", "sent", "spikes")

    def __init__(self, params: LinkDirectionParams, rng: np.random.Generator) -> None:
        self.params = params
        self.rng = rng
        self.last_send_ns = _NEVER_NS
        self.last_delivery_ns = _NEVER_NS
        self.sent = 0
        self.lost = 0
        self.spikes = 0


class Link:
    """Both directions of the FCU <-> companion link; deterministic for a given seed."""

    def __init__(self, params: LinkParams) -> None:
        self.params = params
        to_fcu_seq, to_companion_seq = np.random.SeedSequence(params.seed).spawn(2)
        self._states = {
            LinkDirection.TO_FCU: _DirectionState(params.to_fcu, np.random.default_rng(to_fcu_seq)),
            LinkDirection.TO_COMPANION: _DirectionState(
                params.to_companion, np.random.default_rng(to_companion_seq)
            ),
        }

    @property
    def clock(self) -> FcuClock:
        """The FCU's clock (from the parameters)."""
        return self.params.clock

    def send(self, direction: LinkDirection, send_time_ns: int, size_bytes: int) -> int | None:
        """Put a ``size_bytes`` (CDR) message on the line at ``send_time_ns`` [sim ns].

        Returns its delivery time [sim ns], or None if it is lost. Send times must not
        decrease within a direction (LinkOrderError otherwise).
        """
        state = self._states[direction]
        if send_time_ns < state.last_send_ns:
            raise LinkOrderError(
                f"{direction.value}: send at {send_time_ns} ns is before the previous send "
                f"at {state.last_send_ns} ns"
            )
        if size_bytes < 0:
            raise ValueError(f"size_bytes={size_bytes}: must be >= 0")
        p = state.params
        u_loss, u_spike, u_magnitude = state.rng.random(3)
        jitter_us = float(state.rng.gamma(p.jitter_shape, p.jitter_scale_us))
        state.last_send_ns = send_time_ns
        state.sent += 1
        if u_loss < p.loss_probability:
            state.lost += 1
            return None
        delay_us = p.base_latency_us + jitter_us
        if u_spike < p.spike_probability:
            state.spikes += 1
            delay_us += p.spike_min_us + u_magnitude * (p.spike_max_us - p.spike_min_us)
        wire_ns = p.wire_time_ns(size_bytes)
        delivery_ns = max(
            send_time_ns + round(delay_us * _NS_PER_US) + wire_ns,
            state.last_delivery_ns + wire_ns,
        )
        state.last_delivery_ns = delivery_ns
        return delivery_ns

    def counters(self, direction: LinkDirection) -> LinkCounters:
        """A snapshot of one direction's counters."""
        state = self._states[direction]
        return LinkCounters(sent=state.sent, lost=state.lost, spikes=state.spikes)
