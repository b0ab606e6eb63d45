"""FCU clock: boot offset and skew against simulated time, integer-exact, and its inverse."""

from __future__ import annotations

import math
from fractions import Fraction

import pytest
from hypothesis import given
from hypothesis import strategies as st

from runtime.errors import ParameterError
from sim.fcu.clock import BOOT_OFFSET_RANGE_US, SKEW_RANGE_PPM, FcuClock

S_NS = 1_000_000_000

clocks = st.builds(
    FcuClock,
    boot_offset_us=st.integers(*BOOT_OFFSET_RANGE_US),
    skew_ppm=st.floats(*SKEW_RANGE_PPM, allow_nan=False),
)
sim_times_ns = st.integers(0, 10**7 * S_NS)  # up to about 116 days


def test_fcu_clock_reads_its_boot_offset_at_sim_time_zero() -> None:
    assert FcuClock(boot_offset_us=25_000_000, skew_ppm=20.0).fcu_time_us(0) == 25_000_000


def test_50_ppm_fast_clock_gains_5000_us_in_100_s_on_top_of_its_offset() -> None:
    clock = FcuClock(boot_offset_us=7_000_123, skew_ppm=50.0)
    assert clock.fcu_time_us(100 * S_NS) == 7_000_123 + 100_000_000 + 5_000
    assert clock.fcu_time_us(100 * S_NS) - clock.fcu_time_us(0) == 100_005_000


def test_negative_skew_means_the_fcu_clock_runs_slow() -> None:
    clock = FcuClock(boot_offset_us=0, skew_ppm=-50.0)
    assert clock.fcu_time_us(100 * S_NS) == 100_000_000 - 5_000


def test_ideal_clock_is_simulated_time_in_microseconds() -> None:
    clock = FcuClock.ideal()
    assert clock.fcu_time_us(0) == 0
    assert clock.fcu_time_us(1_999) == 1
    assert clock.fcu_time_us(123_456_789_000) == 123_456_789
    assert clock.sim_time_ns(123_456_789) == 123_456_789_000


def test_times_are_python_ints() -> None:
    clock = FcuClock(boot_offset_us=10, skew_ppm=12.5)
    assert type(clock.fcu_time_us(10**12)) is int
    assert type(clock.sim_time_ns(10**9)) is int


def test_skew_is_applied_to_the_nearest_part_per_billion() -> None:
    assert FcuClock(0, 12.3456).skew_ppb == 12_346
    # 1000 s at 12.346 ppm gain exactly 12346 us.
    assert FcuClock(0, 12.3456).fcu_time_us(1000 * S_NS) == 1_000_000_000 + 12_346


@given(clocks, sim_times_ns)
def test_fcu_time_matches_the_documented_real_formula(clock: FcuClock, t_ns: int) -> None:
    # boot_offset_us + floor(t_ns * (1 + skew_ppm * 1e-6) / 1000), skew to the nearest ppb.
    skew = Fraction(clock.skew_ppb, 10**9)
    assert abs(skew - Fraction(clock.skew_ppm) / 10**6) <= Fraction(1, 2 * 10**9)
    exact_us = clock.boot_offset_us + Fraction(t_ns) * (1 + skew) / 1000
    assert clock.fcu_time_us(t_ns) == math.floor(exact_us)


@given(clocks, sim_times_ns, sim_times_ns)
def test_fcu_time_is_monotonic(clock: FcuClock, a_ns: int, b_ns: int) -> None:
    lo, hi = sorted((a_ns, b_ns))
    assert clock.fcu_time_us(lo) <= clock.fcu_time_us(hi)


@given(clocks, st.integers(0, 10**13))
def test_sim_time_of_an_fcu_reading_maps_back_to_that_reading(clock: FcuClock, dt_us: int) -> None:
    fcu_us = clock.boot_offset_us + dt_us
    t_ns = clock.sim_time_ns(fcu_us)
    assert clock.fcu_time_us(t_ns) == fcu_us
    # ... and it is the first such simulated nanosecond.
    assert clock.fcu_time_us(t_ns - 1) == fcu_us - 1


@given(clocks, sim_times_ns)
def test_sim_time_round_trip_is_within_the_fcu_microsecond(clock: FcuClock, t_ns: int) -> None:
    fcu_us = clock.fcu_time_us(t_ns)
    assert clock.sim_time_ns(fcu_us) <= t_ns < clock.sim_time_ns(fcu_us + 1)


@pytest.mark.parametrize(
    ("kwargs", "key", "allowed"),
    [
        ({"boot_offset_us": -1, "skew_ppm": 0.0}, "boot_offset_us", "[0, 1000000000000000] us"),
        ({"boot_offset_us": 1.5, "skew_ppm": 0.0}, "boot_offset_us", "integer"),
        ({"boot_offset_us": 0, "skew_ppm": 1500.0}, "skew_ppm", "[-1000, 1000] ppm"),
        ({"boot_offset_us": 0, "skew_ppm": float("nan")}, "skew_ppm", "[-1000, 1000] ppm"),
        ({"boot_offset_us": 0, "skew_ppm": "20"}, "skew_ppm", "number"),
    ],
)
def test_bad_clock_parameters_name_the_key_and_the_allowed_values(
    kwargs: dict[str, object], key: str, allowed: str
) -> None:
    with pytest.raises(ParameterError) as info:
        FcuClock(**kwargs)  # type: ignore[arg-type]
    assert info.value.key == key
    assert allowed in str(info.value)
    assert str(info.value).startswith(f"{key}: ")
