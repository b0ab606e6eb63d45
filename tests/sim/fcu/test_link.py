"""FCU <-> companion link: configured latency, Table 3 calibration, loss, spikes, FIFO, YAML."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from interfaces.px4.seed000 import (
    TABLE3_MESSAGE_SIZE_BYTES,
    TABLE3_TO_COMPANION,
    TABLE3_TO_FCU,
    LatencyFigure,
)
from runtime.errors import ParameterError
from runtime.parameters import (
    config_path,
    load_parameters,
    parameters_from_mapping,
)
from sim.fcu.clock import FcuClock
from sim.fcu.link import (
    LINK_NODE_NAME,
    AddedDelay,
    Link,
    LinkDirection,
    LinkDirectionParams,
    LinkOrderError,
    LinkParams,
    calibrate_direction,
)

TO_FCU = LinkDirection.TO_FCU
TO_COMPANION = LinkDirection.TO_COMPANION
TABLE3 = {TO_FCU: TABLE3_TO_FCU, TO_COMPANION: TABLE3_TO_COMPANION}
PERIOD_200HZ_NS = 5_000_000  # the seed's message rate (section 2.9, Tables 1-2)

DEFAULTS = load_parameters(LinkParams, LINK_NODE_NAME)


def fixed_direction(**overrides: object) -> LinkDirectionParams:
    """A direction with no randomness unless ``overrides`` add it."""
    base = LinkDirectionParams(
        base_latency_us=300.0,
        jitter_shape=1.0,
        jitter_scale_us=0.0,
        spike_probability=0.0,
        spike_min_us=0.0,
        spike_max_us=0.0,
        loss_probability=0.0,
        baud_rate=921_600,
        bits_per_byte=10,
        framing_overhead_bytes=0,
    )
    return replace(base, **overrides)  # type: ignore[arg-type]


def params_with(direction: LinkDirectionParams, seed: int = 0) -> LinkParams:
    return LinkParams(to_fcu=direction, to_companion=direction, seed=seed)


def latencies_us(
    link: Link,
    direction: LinkDirection,
    n: int,
    size_bytes: int = TABLE3_MESSAGE_SIZE_BYTES,
    period_ns: int = PERIOD_200HZ_NS,
) -> npt.NDArray[np.float64]:
    """One-way latencies [us] of ``n`` messages sent every ``period_ns``; NaN where lost."""
    out = np.empty(n)
    for i in range(n):
        send_ns = 1_000_000_000 + i * period_ns
        delivery = link.send(direction, send_ns, size_bytes)
        out[i] = math.nan if delivery is None else (delivery - send_ns) / 1000
    return out


# -- the configured latency ----------------------------------------------------------------


def test_link_adds_the_configured_latency_plus_the_wire_time() -> None:
    link = Link(params_with(fixed_direction(base_latency_us=300.0, framing_overhead_bytes=5)))
    # (115 + 5) bytes * 10 bit / 921600 bit/s = 1302.083.. us, rounded up to the ns.
    assert link.params.to_fcu.wire_time_ns(115) == 1_302_084
    assert link.send(TO_FCU, 10_000_000, 115) == 10_000_000 + 300_000 + 1_302_084
    assert link.send(TO_COMPANION, 10_000_000, 0) == 10_000_000 + 300_000 + 54_254


def test_wire_time_is_bytes_times_bits_over_baud() -> None:
    direction = fixed_direction(baud_rate=115_200, bits_per_byte=11, framing_overhead_bytes=3)
    assert direction.wire_time_ns(97) == math.ceil(100 * 11 * 1e9 / 115_200)


def test_null_link_delivers_at_the_send_time_and_loses_nothing() -> None:
    link = Link(LinkParams.null())
    for t_ns, size in [(0, 115), (5, 10_000), (5, 1), (1_000_000, 0)]:
        assert link.send(TO_FCU, t_ns, size) == t_ns
        assert link.send(TO_COMPANION, t_ns, size) == t_ns
    assert link.counters(TO_FCU).sent == 4
    assert link.counters(TO_FCU).lost == 0
    assert link.clock == FcuClock.ideal()


# -- calibration against seed 000 Table 3 -----------------------------------------------------


@pytest.mark.parametrize("direction", [TO_FCU, TO_COMPANION])
def test_the_idle_link_leaves_room_for_what_the_path_adds(direction: LinkDirection) -> None:
    """config/fcu_link.yaml is fitted end to end (quadmission.experiments.latency.fit_link;
    the figures themselves are checked in tests/quadmission/experiments/test_latency.py): the
    FIFO line adds some
    queueing, so the idle link's own moments sit a little under Table 3, never above."""
    params = DEFAULTS.direction(direction)
    target = TABLE3[direction]
    mean_us = params.mean_latency_us(TABLE3_MESSAGE_SIZE_BYTES)
    assert params.wire_time_ns(TABLE3_MESSAGE_SIZE_BYTES) / 1000 < mean_us <= target.mean_us
    assert mean_us > 0.95 * target.mean_us
    assert 0.7 * target.sd_us < params.latency_sd_us() <= target.sd_us


@pytest.mark.parametrize("direction", [TO_FCU, TO_COMPANION])
def test_20000_simulated_115_byte_messages_have_the_model_moments(
    direction: LinkDirection,
) -> None:
    params = DEFAULTS.direction(direction)
    samples = latencies_us(Link(DEFAULTS), direction, 20_000)
    delivered = samples[~np.isnan(samples)]
    # Standard errors at n = 20000: mean ~0.1 %, sd ~2 % (to_fcu's gamma is very skewed).
    assert delivered.mean() == pytest.approx(
        params.mean_latency_us(TABLE3_MESSAGE_SIZE_BYTES), rel=0.02), "mean off the model"
    assert delivered.std(ddof=1) == pytest.approx(params.latency_sd_us(), rel=0.05), (
        "sd off the model")


def test_calibrating_to_a_direction_s_own_moments_gives_its_jitter_back() -> None:
    for direction in (TO_FCU, TO_COMPANION):
        params = DEFAULTS.direction(direction)
        own = LatencyFigure(params.mean_latency_us(TABLE3_MESSAGE_SIZE_BYTES),
                            params.latency_sd_us())
        refit = calibrate_direction(own, replace(params, jitter_shape=1.0, jitter_scale_us=1.0))
        assert refit.jitter_shape == pytest.approx(params.jitter_shape, rel=1e-9)
        assert refit.jitter_scale_us == pytest.approx(params.jitter_scale_us, rel=1e-9)


@settings(max_examples=50, deadline=None)
@given(st.floats(0.0, 50.0), st.floats(0.0, 3000.0))
def test_calibration_leaves_the_added_delay_room(added_mean_us: float,
                                                added_var_us2: float) -> None:
    """Link moments plus the added delay's moments are the target's."""
    added = AddedDelay(added_mean_us, added_var_us2)
    for direction in (TO_FCU, TO_COMPANION):
        target = TABLE3[direction]
        params = calibrate_direction(target, DEFAULTS.direction(direction), added=added)
        assert params.mean_latency_us(TABLE3_MESSAGE_SIZE_BYTES) + added_mean_us == (
            pytest.approx(target.mean_us, rel=1e-9))
        assert params.latency_sd_us() ** 2 + added_var_us2 == pytest.approx(
            target.sd_us**2, rel=1e-9)


def test_a_measured_figure_equal_to_the_target_changes_nothing() -> None:
    for direction in (TO_FCU, TO_COMPANION):
        params = DEFAULTS.direction(direction)
        target = TABLE3[direction]
        added = AddedDelay.measured(target, params)
        refit = calibrate_direction(target, params, added=added)
        assert refit.jitter_shape == pytest.approx(params.jitter_shape, rel=1e-9)
        assert refit.jitter_scale_us == pytest.approx(params.jitter_scale_us, rel=1e-9)


def test_a_poll_adds_half_its_period_and_a_uniform_spread() -> None:
    wait = np.random.default_rng(0).uniform(0.0, 2000.0, 200_000)
    assert AddedDelay.poll(2000.0).mean_us == pytest.approx(wait.mean(), rel=0.01)
    assert AddedDelay.poll(2000.0).variance_us2 == pytest.approx(wait.var(), rel=0.01)
    with pytest.raises(ParameterError, match="must be > 0"):
        AddedDelay.poll(0.0)


def test_a_500_hz_poll_cannot_reach_table3_forward_at_any_baud_rate() -> None:
    # even on an ideal line (no wire time) its wait alone spreads wider than 162 us
    ideal_line = replace(DEFAULTS.to_fcu, bits_per_byte=0)
    with pytest.raises(ParameterError, match="leave no variance") as info:
        calibrate_direction(TABLE3_TO_FCU, ideal_line, added=AddedDelay.poll(2000.0))
    assert info.value.key == "added"


def test_calibration_names_the_baud_rate_a_mean_needs() -> None:
    # 1329 us - 500 us added leave 829 us for 115 bytes, 1150 bits, on the wire
    template = replace(DEFAULTS.to_fcu, spike_probability=0.0, base_latency_us=0.0)
    added = AddedDelay(500.0, 0.0)
    with pytest.raises(ParameterError, match="more than 1,387,214 baud") as info:
        calibrate_direction(TABLE3_TO_FCU, template, added=added)
    assert info.value.key == "baud_rate"
    faster = calibrate_direction(TABLE3_TO_FCU, replace(template, baud_rate=1_500_000),
                                 added=added)
    assert faster.mean_latency_us(TABLE3_MESSAGE_SIZE_BYTES) == pytest.approx(829.0)


def test_calibration_refuses_a_floor_above_the_target_mean() -> None:
    # Micro XRCE-DDS framing (~19 bytes) pushes 115 bytes past 1329 us at 921600 baud.
    template = replace(DEFAULTS.to_fcu, framing_overhead_bytes=19)
    with pytest.raises(ParameterError, match="leave no room under the target mean 1329"):
        calibrate_direction(TABLE3_TO_FCU, template)


def test_calibration_refuses_spikes_wider_than_the_target_sd() -> None:
    template = replace(DEFAULTS.to_fcu, spike_probability=0.5)
    with pytest.raises(ParameterError) as info:
        calibrate_direction(LatencyFigure(mean_us=5000.0, sd_us=100.0), template)
    assert info.value.key == "spike_probability"


def test_larger_messages_take_longer_by_exactly_the_wire_time_difference() -> None:
    small, large = 115, 1000
    period_ns = 20_000_000  # long enough that the FIFO never holds a message back
    a = latencies_us(Link(DEFAULTS), TO_COMPANION, 3000, small, period_ns)
    b = latencies_us(Link(DEFAULTS), TO_COMPANION, 3000, large, period_ns)
    extra_us = (
        DEFAULTS.to_companion.wire_time_ns(large) - DEFAULTS.to_companion.wire_time_ns(small)
    ) / 1000
    assert extra_us == pytest.approx((large - small) * 10 / 921_600 * 1e6, abs=1e-3)
    lost = np.isnan(a)
    np.testing.assert_array_equal(lost, np.isnan(b))  # the same messages are lost
    np.testing.assert_allclose(b[~lost] - a[~lost], extra_us, rtol=0, atol=1e-9)
    expected = DEFAULTS.to_companion.mean_latency_us(large) - DEFAULTS.to_companion.mean_latency_us(
        small
    )
    assert expected == pytest.approx(extra_us)


# -- loss and spikes -------------------------------------------------------------------------


@pytest.mark.parametrize("loss", [0.001, 0.05, 0.3])
def test_loss_rate_matches_the_configured_probability(loss: float) -> None:
    n = 20_000
    link = Link(params_with(fixed_direction(loss_probability=loss), seed=3))
    samples = latencies_us(link, TO_FCU, n)
    lost = int(np.isnan(samples).sum())
    assert link.counters(TO_FCU).lost == lost
    assert link.counters(TO_FCU).delivered == n - lost
    sigma = math.sqrt(n * loss * (1 - loss))
    assert abs(lost - n * loss) < 4 * sigma + 1, f"{lost} lost, expected about {n * loss:.0f}"


def test_certain_loss_delivers_nothing() -> None:
    link = Link(params_with(fixed_direction(loss_probability=1.0)))
    assert all(link.send(TO_FCU, t, 115) is None for t in range(0, 10**8, 10**6))


def test_spikes_appear_at_the_configured_rate_and_size() -> None:
    n, p = 20_000, 0.1
    direction = fixed_direction(
        base_latency_us=0.0, spike_probability=p, spike_min_us=2000.0, spike_max_us=4000.0
    )
    link = Link(params_with(direction, seed=11))
    period_ns = 10_000_000  # longer than any spike: the FIFO never holds a message back
    wire_us = direction.wire_time_ns(115) / 1000
    extra_us = latencies_us(link, TO_FCU, n, period_ns=period_ns) - wire_us
    spiked = extra_us[extra_us > 1e-3]
    assert link.counters(TO_FCU).spikes == spiked.size
    assert abs(spiked.size - n * p) < 4 * math.sqrt(n * p * (1 - p))
    assert spiked.min() >= 2000.0 - 1e-3
    assert spiked.max() <= 4000.0 + 1e-3
    assert spiked.mean() == pytest.approx(3000.0, rel=0.03)  # uniform in between


def test_default_spike_rate() -> None:
    link = Link(DEFAULTS)
    latencies_us(link, TO_COMPANION, 20_000)
    counters = link.counters(TO_COMPANION)
    p = DEFAULTS.to_companion.spike_probability
    n = counters.delivered
    assert abs(counters.spikes - n * p) < 4 * math.sqrt(n * p * (1 - p))


# -- determinism -----------------------------------------------------------------------------


def test_same_seed_gives_the_same_delays() -> None:
    a = latencies_us(Link(DEFAULTS), TO_FCU, 2000)
    b = latencies_us(Link(DEFAULTS), TO_FCU, 2000)
    np.testing.assert_array_equal(a, b)


def test_different_seeds_give_different_delays() -> None:
    a = latencies_us(Link(replace(DEFAULTS, seed=1)), TO_FCU, 2000)
    b = latencies_us(Link(replace(DEFAULTS, seed=2)), TO_FCU, 2000)
    assert not np.array_equal(a, b, equal_nan=True)


def test_directions_have_independent_streams() -> None:
    alone = latencies_us(Link(DEFAULTS), TO_FCU, 500)
    link = Link(DEFAULTS)
    interleaved = np.empty(500)
    for i in range(500):
        send_ns = 1_000_000_000 + i * PERIOD_200HZ_NS
        link.send(TO_COMPANION, send_ns, 400)
        delivery = link.send(TO_FCU, send_ns, TABLE3_MESSAGE_SIZE_BYTES)
        interleaved[i] = math.nan if delivery is None else (delivery - send_ns) / 1000
    np.testing.assert_array_equal(alone, interleaved)


def test_the_two_directions_do_not_share_a_stream() -> None:
    same = params_with(DEFAULTS.to_companion, seed=5)
    link = Link(same)
    a = [link.send(TO_FCU, i * PERIOD_200HZ_NS, 115) for i in range(200)]
    b = [link.send(TO_COMPANION, i * PERIOD_200HZ_NS, 115) for i in range(200)]
    assert a != b


# -- FIFO ------------------------------------------------------------------------------------

sends = st.lists(
    st.tuples(st.integers(0, 3_000_000), st.integers(0, 2000)),  # (gap ns, size bytes)
    min_size=1,
    max_size=60,
)


@settings(max_examples=200, deadline=None)
@given(sends, st.integers(0, 2**32), st.sampled_from([TO_FCU, TO_COMPANION]))
def test_no_message_overtakes_an_earlier_one(
    gaps_and_sizes: list[tuple[int, int]], seed: int, direction: LinkDirection
) -> None:
    # Frequent, large spikes make later messages want to overtake.
    stressed = replace(DEFAULTS.direction(direction), spike_probability=0.3, loss_probability=0.1)
    link = Link(params_with(stressed, seed=seed))
    t_ns, previous_ns = 0, None
    for gap_ns, size in gaps_and_sizes:
        t_ns += gap_ns
        delivery = link.send(direction, t_ns, size)
        if delivery is None:
            continue
        wire_ns = stressed.wire_time_ns(size)
        assert delivery >= t_ns + wire_ns, "delivered before its bytes were on the line"
        if previous_ns is not None:
            assert delivery >= previous_ns + wire_ns, "overtook or overlapped the previous one"
        previous_ns = delivery


def test_a_send_earlier_than_the_previous_one_is_refused() -> None:
    link = Link(DEFAULTS)
    link.send(TO_FCU, 2_000_000, 115)
    with pytest.raises(LinkOrderError, match="to_fcu"):
        link.send(TO_FCU, 1_999_999, 115)
    link.send(TO_COMPANION, 0, 115)  # the other direction keeps its own order


# -- parameters and YAML ---------------------------------------------------------------------


def test_default_yaml_loads_with_its_clock_and_seed() -> None:
    assert config_path("fcu_link.yaml").name == "fcu_link.yaml"
    clock = Link(DEFAULTS).clock
    assert clock == DEFAULTS.clock
    assert clock.fcu_time_us(0) == DEFAULTS.clock.boot_offset_us  # the FCU's uptime at sim start
    assert DEFAULTS.to_fcu.baud_rate == DEFAULTS.to_companion.baud_rate == 921_600
    assert DEFAULTS.to_fcu.bits_per_byte == 10


def default_doc() -> dict[str, object]:
    doc = yaml.safe_load(config_path("fcu_link.yaml").read_text(encoding="utf-8"))
    assert isinstance(doc, dict)
    return doc


def with_value(path: str, value: object) -> dict[str, object]:
    """The default document with the dotted ``path`` (under ros__parameters) set or removed."""
    doc = default_doc()
    section = doc["fcu_link"]["ros__parameters"]  # type: ignore[index]
    *parents, leaf = path.split(".")
    for key in parents:
        section = section[key]
    if value is _REMOVE:
        del section[leaf]
    else:
        section[leaf] = value
    return doc


_REMOVE = object()
P = "fcu_link"


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        ("to_fcu.loss_probability", 1.5, "outside the allowed range [0, 1]"),
        ("to_companion.base_latency_us", -3.0, "outside the allowed range [0, 1e+06] us"),
        ("to_fcu.baud_rate", 921600.0, "must be an integer in the allowed range"),
        ("to_fcu.baud_rate", 100, "outside the allowed range [300, 100000000] bit/s"),
        ("to_fcu.jitter_shape", "0.75", "must be a number"),
        ("to_fcu.bits_per_byte", True, "must be an integer"),
        ("to_companion.spike_max_us", 100.0, "[spike_min_us = 500.0, 1e+07] us"),
        ("clock.skew_ppm", 5000.0, "outside the allowed range [-1000, 1000] ppm"),
        ("clock.boot_offset_us", -1, "outside the allowed range"),
        ("seed", -1, "outside the allowed range [0, 9223372036854775807]"),
        ("to_fcu.baud", 921600, "unknown key; allowed keys are base_latency_us"),
        ("to_fcu.framing_overhead_bytes", _REMOVE, "missing"),
        ("clock", _REMOVE, "missing"),
        ("to_companion", [1, 2], "expected a mapping"),
    ],
)
def test_yaml_errors_name_the_key_and_the_allowed_range(
    path: str, value: object, message: str
) -> None:
    with pytest.raises(ParameterError) as info:
        parameters_from_mapping(LinkParams, LINK_NODE_NAME, with_value(path, value))
    assert info.value.key == f"{P}.{path}"
    assert message in str(info.value)
    assert str(info.value).startswith(f"{P}.{path}: ")


def test_yaml_file_errors_name_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "fcu_link.yaml"
    bad.write_text(
        config_path("fcu_link.yaml").read_text(encoding="utf-8").replace(
            "loss_probability: 0.001", "loss_probability: 2.0", 1
        ),
        encoding="utf-8",
    )
    with pytest.raises(ParameterError) as info:
        load_parameters(LinkParams, LINK_NODE_NAME, bad)
    assert str(info.value).startswith(f"{bad}: {P}.to_fcu.loss_probability: 2.0 is outside")


def test_parameters_are_validated_when_built_in_code_too() -> None:
    with pytest.raises(ParameterError) as info:
        fixed_direction(spike_probability=-0.1)
    assert str(info.value) == "spike_probability: -0.1 is outside the allowed range [0, 1]"
