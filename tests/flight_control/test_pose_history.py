"""The pose history: bounded span, interpolation in position and orientation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from flight_control.frames import quat_from_yaw, quat_to_yaw
from flight_control.pose_history import PoseHistory, PoseSample, slerp


def _sample(t_s: float, x: float, yaw: float) -> PoseSample:
    return PoseSample(round(t_s * 1e9), np.array([x, 0.0, 1.0]), np.asarray(quat_from_yaw(yaw)),
                      np.array([1.0, 0.0, 0.0]))


def test_interpolates_between_samples() -> None:
    history = PoseHistory(span_ns=10**9)
    history.add(_sample(0.0, 0.0, 0.0))
    history.add(_sample(0.1, 1.0, math.pi / 2))
    mid = history.at(50_000_000)
    assert mid is not None
    assert mid.position == pytest.approx([0.5, 0.0, 1.0])
    assert float(quat_to_yaw(mid.q)) == pytest.approx(math.pi / 4)


def test_forgets_what_is_older_than_its_span_and_refuses_outside() -> None:
    history = PoseHistory(span_ns=500_000_000)
    for k in range(20):
        history.add(_sample(k * 0.1, k * 0.1, 0.0))
    assert history.span == (1_400_000_000, 1_900_000_000)
    assert history.at(1_000_000_000) is None
    assert history.at(2_000_000_000) is None
    exact = history.at(1_500_000_000)
    assert exact is not None and exact.position[0] == pytest.approx(1.5)


def test_answers_exactly_at_the_oldest_and_the_newest_sample_times() -> None:
    """The kept span is closed at both ends: its first and last samples are answered as
    they are, not refused and not interpolated with a neighbour."""
    history = PoseHistory(span_ns=500_000_000)
    for k in range(20):
        history.add(_sample(k * 0.1, k * 0.1, k * 0.05))
    span = history.span
    assert span is not None
    oldest_ns, newest_ns = span
    oldest, newest = history.at(oldest_ns), history.at(newest_ns)
    assert oldest is not None, "refused at the oldest kept time"
    assert newest is not None, "refused at the newest kept time"
    assert (oldest.t_ns, newest.t_ns) == (oldest_ns, newest_ns)
    assert oldest.position[0] == pytest.approx(oldest_ns / 1e9)  # x = t in _sample
    assert newest.position[0] == pytest.approx(newest_ns / 1e9)
    assert float(quat_to_yaw(newest.q)) == pytest.approx(0.5 * newest_ns / 1e9)
    assert history.at(oldest_ns - 1) is None and history.at(newest_ns + 1) is None


def test_out_of_order_samples_are_ignored() -> None:
    history = PoseHistory(span_ns=10**9)
    history.add(_sample(0.2, 2.0, 0.0))
    history.add(_sample(0.1, 1.0, 0.0))
    assert len(history) == 1


@given(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(0.0, 1.0))
def test_slerp_stays_unit_and_hits_its_ends(yaw0: float, yaw1: float, u: float) -> None:
    q0, q1 = np.asarray(quat_from_yaw(yaw0)), np.asarray(quat_from_yaw(yaw1))
    q = slerp(q0, q1, u)
    assert np.linalg.norm(q) == pytest.approx(1.0)
    assert abs(float(np.dot(slerp(q0, q1, 0.0), q0))) == pytest.approx(1.0)
    assert abs(float(np.dot(slerp(q0, q1, 1.0), q1))) == pytest.approx(1.0)
