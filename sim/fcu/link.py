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

Calibration (seed 000, Table 3, MicroXRCE-DDS - ROS 2 row, in
:mod:`interfaces.px4.seed000`): the mean and standard deviation of a 115-byte message's
latency each way, measured end to end: where the FCU's estimator parses it (companion ->
FCU), and where the companion node receives it (FCU -> companion). The table
gives two moments, so the shape is a choice: a floor plus a gamma tail (as OS and
serial-link latency looks) plus rare load spikes (the latency peaks of the seed's Figure 8).
:func:`calibrate_direction` keeps the floor, the spikes and the line settings and solves
the gamma's shape and scale so that the link's moments at the reference size, plus what
the rest of the path adds (:class:`AddedDelay`, taken as independent: means and variances
add), are the table's. What the path adds is a consumer's wait (:meth:`AddedDelay.poll`)
or whatever an end-to-end measurement shows beyond the idle link
(:meth:`AddedDelay.measured`: queueing behind other messages on the FIFO line); the
defaults in ``config/fcu_link.yaml`` were fitted to the latency experiment that way
(``quadmission.experiments.latency.fit_link``). The wire time is physics: at the seed's
921 600 baud,
8N1, 115 bytes take 1247.8 us, which leaves only 81 us of mean for everything else
companion -> FCU. That direction has no floor, no framing overhead and a skewed gamma,
and no room for a polled consumer: a 500 Hz poll alone adds 1000 +/- 577 us, which no
baud rate absorbs (the seed's FCU firmware consumed its inputs on arrival, section 4.3).
:func:`calibrate_direction` names the problem (and the baud rate a mean would need).

Pure module: numpy and PyYAML, no runtime, no MuJoCo.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import NamedTuple

import numpy as np

from interfaces.px4.seed000 import (
    TABLE3_MESSAGE_SIZE_BYTES,
    LatencyFigure,
)
from runtime.errors import ParameterError
from runtime.parameters import param, validate_parameters
from sim.errors import SimError
from sim.fcu.clock import FcuClock

__all__ = [
    "LINK_NODE_NAME",
    "AddedDelay",
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


class AddedDelay(NamedTuple):
    """What the path adds on top of the link's own latency, as two moments: mean [us]
    and variance [us^2]. Taken as independent of the link's latency (moments add)."""

    mean_us: float
    variance_us2: float

    @classmethod
    def none(cls) -> AddedDelay:
        """Nothing added: the figure is the link's own."""
        return cls(0.0, 0.0)

    @classmethod
    def poll(cls, period_us: float) -> AddedDelay:
        """The wait for a consumer that polls every ``period_us`` at a phase unrelated to the
        arrivals: uniform on ``[0, period_us)``, mean ``P/2``, variance ``P^2/12``."""
        if not period_us > 0.0:
            raise ParameterError(f"poll period {period_us!r} us: must be > 0 us", key="added")
        return cls(period_us / 2.0, period_us**2 / 12.0)

    @classmethod
    def measured(cls, end_to_end: LatencyFigure, link: LinkDirectionParams,
                 size_bytes: int = TABLE3_MESSAGE_SIZE_BYTES) -> AddedDelay:
        """What a measured ``end_to_end`` figure holds beyond ``link``'s own idle-line
        moments (queueing behind other messages on the FIFO line, a consumer's wait...)."""
        return cls(end_to_end.mean_us - link.mean_latency_us(size_bytes),
                   end_to_end.sd_us**2 - link.latency_sd_us() ** 2)


def calibrate_direction(
    target: LatencyFigure,
    template: LinkDirectionParams,
    size_bytes: int = TABLE3_MESSAGE_SIZE_BYTES,
    added: AddedDelay | None = None,
) -> LinkDirectionParams:
    """``template`` with the gamma jitter solved so that ``size_bytes`` messages, plus the
    ``added`` delay of the rest of the path, have ``target``'s mean and standard deviation.

    The floor, spikes, loss and line settings of ``template`` are kept; with
    ``m = mean - added mean - floor - wire time - p * spike mean`` and
    ``v = sd^2 - added variance - spike variance`` the gamma has shape ``m^2 / v`` and
    scale ``v / m``. Raises ParameterError when the template leaves no positive mean or
    variance for the jitter; a mean that only a faster line can fit names the baud rate
    it would need (the wire time cannot shrink otherwise).
    """
    added = added or AddedDelay.none()
    wire_us = template.wire_time_ns(size_bytes) / _NS_PER_US
    spike_us = template.spike_probability * template.spike_mean_us
    room_us = target.mean_us - added.mean_us - template.base_latency_us - spike_us
    jitter_mean_us = room_us - wire_us
    jitter_var_us2 = target.sd_us**2 - added.variance_us2 - _spike_variance_us2(template)
    if jitter_mean_us <= 0.0:
        bits = (size_bytes + template.framing_overhead_bytes) * template.bits_per_byte
        need = (f"the line would need more than {bits / (room_us * 1e-6):,.0f} baud"
                if room_us > 0.0 else "no baud rate can fit it")
        raise ParameterError(
            f"floor {template.base_latency_us:g} us + wire time {wire_us:.1f} us at "
            f"{template.baud_rate} baud + mean spike {spike_us:.1f} us + added delay "
            f"{added.mean_us:.1f} us leave no room under the target mean "
            f"{target.mean_us:g} us: {need}",
            key="baud_rate" if room_us > 0.0 else "base_latency_us",
        )
    if jitter_var_us2 <= 0.0:
        spike_sd_us = math.sqrt(_spike_variance_us2(template))
        added_sd_us = math.sqrt(max(added.variance_us2, 0.0))
        raise ParameterError(
            f"the spikes (standard deviation {spike_sd_us:.1f} us) and the added delay "
            f"({added_sd_us:.1f} us) leave no variance for the jitter under the target "
            f"{target.sd_us:g} us",
            key="spike_probability" if spike_sd_us >= target.sd_us else "added",
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


_DRAW_BLOCK = 512  # messages whose random numbers are drawn at once


class _DirectionState:
    """Random stream, FIFO state and counters of one direction."""

    __slots__ = ("_draws", "last_delivery_ns", "last_send_ns", "lost", "params", "rng",
                 "sent", "spikes", "wire_ns")

    def __init__(self, params: LinkDirectionParams, rng: np.random.Generator) -> None:
        self.params = params
        self.rng = rng
        self._draws: Iterator[tuple[float, float, float, float]] = iter(())
        self.wire_ns: dict[int, int] = {}  # params.wire_time_ns by message size, as met
        self.last_send_ns = _NEVER_NS
        self.last_delivery_ns = _NEVER_NS
        self.sent = 0
        self.lost = 0
        self.spikes = 0

    def draw(self) -> tuple[float, float, float, float]:
        """The next message's random numbers: three uniforms (loss, spike, spike size) and
        the gamma jitter [us]. Drawn :data:`_DRAW_BLOCK` messages at a time (one call into
        numpy per block, not two per message: each call gives up the GIL, and on a busy
        process taking it back is what a message cost), the same stream for a seed."""
        try:
            return next(self._draws)
        except StopIteration:
            p = self.params
            uniforms = self.rng.random((_DRAW_BLOCK, 3))
            jitters = self.rng.gamma(p.jitter_shape, p.jitter_scale_us, _DRAW_BLOCK)
            self._draws = iter([(*u, j) for u, j in zip(uniforms.tolist(), jitters.tolist(),
                                                        strict=True)])
            return next(self._draws)


class Link:
    """Both directions of the FCU <-> companion link; deterministic for a given seed."""

    def __init__(self, params: LinkParams) -> None:
        self.params = params
        to_fcu_seq, to_companion_seq = np.random.SeedSequence(params.seed).spawn(2)
        self._to_fcu = _DirectionState(params.to_fcu, np.random.default_rng(to_fcu_seq))
        self._to_companion = _DirectionState(params.to_companion,
                                             np.random.default_rng(to_companion_seq))
        self.down = False
        """While True every message, both ways, is lost (a fault: the cable is out). The
        random draws go on as usual, so the link after the outage is the one it would
        have been."""
        self.extra_latency_us = 0.0
        """Added to every message's latency, both ways (a fault: a latency spike)."""
        self.extra_loss_probability = 0.0
        """A loss probability both ways, when above the configured one (a fault: a burst
        of lost packets; the same draw decides, so the run stays the same seed's)."""

    def _state(self, direction: LinkDirection) -> _DirectionState:
        # not a dict keyed by the enum: an Enum's hash is a Python call
        return self._to_fcu if direction is LinkDirection.TO_FCU else self._to_companion

    @property
    def clock(self) -> FcuClock:
        """The FCU's clock (from the parameters)."""
        return self.params.clock

    def send(self, direction: LinkDirection, send_time_ns: int, size_bytes: int) -> int | None:
        """Put a ``size_bytes`` (CDR) message on the line at ``send_time_ns`` [sim ns].

        Returns its delivery time [sim ns], or None if it is lost. Send times must not
        decrease within a direction (LinkOrderError otherwise).
        """
        state = self._to_fcu if direction is LinkDirection.TO_FCU else self._to_companion
        if send_time_ns < state.last_send_ns:
            raise LinkOrderError(
                f"{direction.value}: send at {send_time_ns} ns is before the previous send "
                f"at {state.last_send_ns} ns"
            )
        if size_bytes < 0:
            raise ValueError(f"size_bytes={size_bytes}: must be >= 0")
        p = state.params
        u_loss, u_spike, u_magnitude, jitter_us = state.draw()
        state.last_send_ns = send_time_ns
        state.sent += 1
        if u_loss < p.loss_probability or self.down or u_loss < self.extra_loss_probability:
            state.lost += 1
            return None
        delay_us = p.base_latency_us + jitter_us + self.extra_latency_us
        if u_spike < p.spike_probability:
            state.spikes += 1
            delay_us += p.spike_min_us + u_magnitude * (p.spike_max_us - p.spike_min_us)
        wire_ns = state.wire_ns.get(size_bytes)
        if wire_ns is None:
            wire_ns = state.wire_ns[size_bytes] = p.wire_time_ns(size_bytes)
        delivery_ns = max(
            send_time_ns + round(delay_us * _NS_PER_US) + wire_ns,
            state.last_delivery_ns + wire_ns,
        )
        state.last_delivery_ns = delivery_ns
        return delivery_ns

    def counters(self, direction: LinkDirection) -> LinkCounters:
        """A snapshot of one direction's counters."""
        state = self._state(direction)
        return LinkCounters(sent=state.sent, lost=state.lost, spikes=state.spikes)
