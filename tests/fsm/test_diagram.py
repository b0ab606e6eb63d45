"""The docs' state diagram (docs/mission.md) is the one the code generates, and it draws every
transition."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from fsm.diagram import BEGIN, END, mermaid, readme_block
from fsm.mission_table import ERROR_POLICY, TRANSITIONS
from quadmission.cli import main

PAGE = Path(__file__).resolve().parents[2] / "docs" / "mission.md"


def test_the_docs_block_is_what_quadmission_fsm_diagram_prints(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fsm", "--diagram"]) == 0
    printed = capsys.readouterr().out
    assert printed == readme_block()
    text = PAGE.read_text(encoding="utf-8")
    start, end = text.index(BEGIN), text.index(END) + len(END) + 1
    assert text[start:end] == printed, "docs/mission.md is stale: paste `quadmission fsm --diagram`"


def test_the_diagram_has_one_edge_per_transition_and_a_row_per_cause() -> None:
    edges = re.findall(r"^    (\w+) --> (\w+) : (\w+)", mermaid(), re.M)
    triggers = sorted(t.trigger for t in TRANSITIONS)
    assert sorted(e[2] for e in edges if e[2] != "resume") == triggers
    assert any(e[:3] == ("paused", "mission", "resume") for e in edges)
    assert any(e[:3] == ("held", "mission", "resume") for e in edges)
    assert any(e[:3] == ("held", "returning", "resume") for e in edges)
    for cause, policy in ERROR_POLICY.items():
        transient = "HOLD, then RESUME" if policy.transient else "-"
        assert f"| `{cause.value}` | {policy.reaction.name} | {transient} |" in readme_block()
