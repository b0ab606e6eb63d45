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


def test_interpolates_position_velocity_and_time_between_two_later_samples() -> None:
    """Away from t = 0 and with a changing velocity: 1.05 s is a quarter of the way from
    the sample at 1.0 s to the one at 1.2 s."""
    history = PoseHistory(span_ns=10**9)
    history.add(PoseSample(1_000_000_000, np.array([1.0, 4.0, 2.0]),
                           np.asarray(quat_from_yaw(0.2)), np.array([1.0, -2.0, 0.5])))
    history.add(PoseSample(1_200_000_000, np.array([3.0, 2.0, 2.4]),
                           np.asarray(quat_from_yaw(0.6)), np.array([3.0, 2.0, -0.5])))
    pose = history.at(1_050_000_000)
    assert pose is not None
    assert pose.t_ns == 1_050_000_000
    assert pose.position == pytest.approx([1.5, 3.5, 2.1])
    assert pose.velocity == pytest.approx([1.5, -1.0, 0.25])
    assert float(quat_to_yaw(pose.q)) == pytest.approx(0.3)


def test_at_a_sample_time_the_answer_is_that_sample_exactly() -> None:
    """No interpolation round-off at a sample time, in the middle of the history too."""
    history = PoseHistory(span_ns=10**9)
    xs = [0.3, 0.7, 0.1, 0.5, 0.2]  # 0.7 + 1.0 * (0.1 - 0.7) is not 0.1 in floating point
    samples = [_sample(0.1 * k, x, 0.3 * k) for k, x in enumerate(xs)]
    for sample in samples:
        history.add(sample)
    for sample in samples:
        pose = history.at(sample.t_ns)
        assert pose is not None and pose.t_ns == sample.t_ns
        assert np.array_equal(pose.position, sample.position)
        assert np.array_equal(pose.q, sample.q)
        assert np.array_equal(pose.velocity, sample.velocity)


def test_a_second_sample_at_the_newest_time_is_ignored() -> None:
    history = PoseHistory(span_ns=10**9)
    history.add(_sample(0.2, 2.0, 0.0))
    history.add(_sample(0.2, 5.0, 0.0))
    assert len(history) == 1
    again = history.at(200_000_000)
    assert again is not None and again.position[0] == 2.0


def test_the_span_must_be_positive() -> None:
    with pytest.raises(ValueError, match="span_ns: 0 must be > 0"):
        PoseHistory(span_ns=0)
    one_ns = PoseHistory(span_ns=1)
    one_ns.add(_sample(0.0, 0.0, 0.0))
    assert one_ns.span == (0, 0)


def test_slerp_between_nearly_equal_orientations_goes_part_of_the_way() -> None:
    """Yaw 0.02 rad apart (the normalised-linear branch): a quarter of the way is 0.005."""
    q0, q1 = np.asarray(quat_from_yaw(0.1)), np.asarray(quat_from_yaw(0.12))
    assert float(np.dot(q0, q1)) > 0.9995
    assert float(quat_to_yaw(slerp(q0, q1, 0.25))) == pytest.approx(0.105, abs=1e-6)
    assert float(quat_to_yaw(slerp(q0, q1, 1.0))) == pytest.approx(0.12, abs=1e-12)


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


def test_missing_says_why_there_is_no_pose() -> None:
    history = PoseHistory(span_ns=10**9)
    assert history.missing(0) == "no odometry kept yet"
    history.add(_sample(1.0, 0.0, 0.0))
    history.add(_sample(1.5, 1.0, 0.0))
    assert history.at(2_000_000_000) is None
    assert history.missing(2_000_000_000) == (
        "2.000 s is outside the kept history [1.000, 1.500] s")
