"""flight_control/policy.py: the words every policy shares. A wrong answer is named, a
finish is a success exactly for the outcomes an action reports as one, the policies end in
these words (not words of their own), and the module stays a leaf every layer may import."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from flight_control import policy
from flight_control.policy import SUCCESSES, Finish, Outcome, PolicyError, Sleep, expect
from fsm import mission_driver
from navigation import navigator_policy, precision_land_policy


def test_the_expected_answer_is_passed_through() -> None:
    answer = Sleep(0.5)
    assert expect(answer, Sleep) is answer


def test_a_wrong_answer_is_named_with_the_kind_expected() -> None:
    with pytest.raises(PolicyError, match=r"expected a Sleep answer, got Finish\("):
        expect(Finish(Outcome.CANCELED, "canceled"), Sleep)
    with pytest.raises(PolicyError, match="expected a Sleep answer, got None"):
        expect(None, Sleep)


@pytest.mark.parametrize("outcome", list(Outcome))
def test_a_finish_succeeds_for_the_outcomes_an_action_reports_as_success(
        outcome: Outcome) -> None:
    # the action files: navigate/land RESULT_OK, explore MARKER_FOUND and COVERED
    succeeded = outcome in (Outcome.SUCCEEDED, Outcome.MARKER_FOUND, Outcome.COVERED)
    assert Finish(outcome, "").success is succeeded
    assert (outcome in SUCCESSES) is succeeded


@pytest.mark.parametrize("module", [navigator_policy, precision_land_policy, mission_driver])
def test_no_policy_defines_an_outcome_or_a_finish_of_its_own(module: object) -> None:
    """One vocabulary: the policies' modules hold the shared classes, or subclasses of them
    that add what only they carry (explore's coverage, the mission's job)."""
    assert getattr(module, "Outcome", Outcome) is Outcome
    for name in ("Finish", "Sleep"):
        mine = getattr(module, name, None)
        assert mine is None or issubclass(mine, getattr(policy, name))


def test_the_vocabulary_is_a_leaf_of_the_standard_library() -> None:
    tree = ast.parse(Path(policy.__file__).read_text(encoding="utf-8"))
    imported = {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert imported <= {"__future__", "dataclasses", "enum", "typing"}, imported
