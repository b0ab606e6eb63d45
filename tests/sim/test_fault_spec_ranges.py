"""Every numeric key of every fault kind, at each bound of its range and just outside, read
from the spec table itself (``KINDS``): a key added to the table is covered as it lands.

At a bound the fault is accepted and keeps the value; one step of a float beyond
(``math.nextafter``) it is refused, the error naming the key, the value and the range.
"""

from __future__ import annotations

import math

import pytest

from sim.fault_spec import KINDS, Duration, Fault, FaultKind, FaultSpecError, Key, parse_fault

NUMERIC_KEYS = [(kind, key) for kind, spec in KINDS.items() for key in spec.keys
                if not key.text]


def spec_with(kind: FaultKind, key: Key, value: float) -> str:
    """A spec string of ``kind`` with ``key=value`` (exactly: repr round-trips), a
    duration where the kind needs one, and its other required keys at their lower bound."""
    head = f"{kind.value}@1" + (":2" if KINDS[kind].duration is Duration.REQUIRED else "")
    others = [f"{k.name}={k.lo!r}" for k in KINDS[kind].keys
              if k.required and k.name != key.name and not k.text]
    texts = [f"{k.name}=somebody" for k in KINDS[kind].keys if k.required and k.text]
    return ",".join([head, f"{key.name}={value!r}", *others, *texts])


def _id(case: tuple[FaultKind, Key]) -> str:
    return f"{case[0].value}.{case[1].name}"


def test_the_table_has_numeric_keys_with_finite_ordered_bounds() -> None:
    assert len(NUMERIC_KEYS) >= 10, "the spec table walk found too few keys"
    for kind, key in NUMERIC_KEYS:
        assert math.isfinite(key.lo) and math.isfinite(key.hi) and key.lo < key.hi, (kind, key)


@pytest.mark.parametrize("case", NUMERIC_KEYS, ids=[_id(c) for c in NUMERIC_KEYS])
def test_a_key_at_each_bound_is_accepted(case: tuple[FaultKind, Key]) -> None:
    kind, key = case
    for bound in (key.lo, key.hi):
        fault = parse_fault(spec_with(kind, key, bound))
        assert fault.kind is kind and fault.value(key.name) == bound
        assert parse_fault(fault.spec()) == fault  # written back, it replays the same
        given: dict[str, float | str] = {**dict(fault.values), **dict(fault.texts)}
        assert Fault.of(kind, 1.0, fault.duration_s, **given) == fault  # made in code too


@pytest.mark.parametrize("case", NUMERIC_KEYS, ids=[_id(c) for c in NUMERIC_KEYS])
def test_a_key_just_outside_its_range_is_refused_naming_key_value_and_range(
        case: tuple[FaultKind, Key]) -> None:
    kind, key = case
    for outside in (math.nextafter(key.lo, -math.inf), math.nextafter(key.hi, math.inf)):
        spec = spec_with(kind, key, outside)
        with pytest.raises(FaultSpecError) as refused:
            parse_fault(spec)
        message = str(refused.value)
        assert message.startswith(f"fault {spec!r}: "), message  # the spec as written
        assert f"{key.name}={outside!r}" in message or f"{key.name}={outside:g}" in message, \
            message
        assert f"is outside [{key.lo:g}, {key.hi:g}]" in message, message
        # the value said is the value refused, not a rounding of it that lies in the range
        said = float(message.rsplit(f"{key.name}=", 1)[1].split(" ")[0])
        assert not key.lo <= said <= key.hi, f"{message}: the value named is in the range"


def test_a_spec_written_back_keeps_every_digit_of_its_values() -> None:
    fault = parse_fault("wind_gust@12.3456789:2.25,force=2.3456789,direction_deg=-0.1")
    assert fault.spec() == "wind_gust@12.3456789:2.25,force=2.3456789,direction_deg=-0.1"
    assert parse_fault(fault.spec()) == fault
