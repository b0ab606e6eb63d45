"""The mission tables drawn for people: a mermaid state diagram and the error policy.

:func:`readme_block` is what ``quadmission fsm --diagram`` prints and what the README
holds between :data:`BEGIN` and :data:`END` (a test checks that they agree). Everything
comes from :mod:`fsm.mission_table`; nothing here is typed twice. Pure module.
"""

from __future__ import annotations

from fsm.mission_table import (
    ERROR_POLICY,
    INITIAL,
    RECOVERABLE,
    RESUMABLE,
    SEPARATOR,
    STATES,
    TRANSITIONS,
    StateSpec,
    walk,
)

BEGIN = "<!-- fsm-diagram:begin (quadmission fsm --diagram) -->"
END = "<!-- fsm-diagram:end -->"


def _ids() -> dict[str, str]:
    """Mermaid ids: composite states by their own name (unique), leaves by their path."""
    ids: dict[str, str] = {}
    for name, spec in walk():
        ids[name] = spec.name if spec.children else name.replace(SEPARATOR, "_")
    if len(set(ids.values())) != len(ids):
        raise ValueError("mermaid ids collide; rename a state")
    return ids


def _declare(specs: tuple[StateSpec, ...], prefix: str, ids: dict[str, str],
             indent: str) -> list[str]:
    lines: list[str] = []
    for spec in specs:
        name = prefix + spec.name
        if spec.children:
            lines.append(f"{indent}state {ids[name]} {{")
            lines.append(f"{indent}    [*] --> {ids[name + SEPARATOR + str(spec.initial)]}")
            lines += _declare(spec.children, name + SEPARATOR, ids, indent + "    ")
            lines.append(f"{indent}}}")
        elif ids[name] != spec.name:
            lines.append(f'{indent}state "{spec.name}" as {ids[name]}')
    return lines


def mermaid() -> str:
    """The meta-machine and the mission machine as one mermaid ``stateDiagram-v2``."""
    ids = _ids()
    lines = ["stateDiagram-v2", f"    [*] --> {ids[INITIAL]}"]
    lines += _declare(STATES, "", ids, "    ")
    for t in TRANSITIONS:
        label = t.trigger + (f" {t.label}" if t.label else "")
        lines.append(f"    {ids[t.source]} --> {ids[t.dest]} : {label}")
    for top in sorted({name.split(SEPARATOR)[0] for name in RESUMABLE}):
        lines.append(f"    paused --> {ids[top]} : resume (to the state paused in)")
    for top in sorted({name.split(SEPARATOR)[0] for name in RECOVERABLE}):
        lines.append(f"    held --> {ids[top]} : resume (clear for the settle time: to the "
                     "state held in)")
    for name, spec in walk():
        if spec.terminal:
            lines.append(f"    {ids[name]} --> [*]")
    return "\n".join(lines) + "\n"


TRANSIENT = "HOLD, then RESUME"  # once clear; else the permanent one (docs/mission.md)


def policy_table() -> str:
    """The error policy as a markdown table: cause, the permanent reaction, the transient
    one (a cause that can clear), why."""
    rows = ["| cause | permanent reaction | transient reaction | why |", "|---|---|---|---|"]
    rows += [f"| `{cause.value}` | {policy.reaction.name} | "
             f"{TRANSIENT if policy.transient else '-'} | {policy.why} |"
             for cause, policy in ERROR_POLICY.items()]
    return "\n".join(rows) + "\n"


def transition_table() -> str:
    """Every transition as one text line: ``source --trigger [condition]--> dest``."""
    rows = [f"{t.source:24s} --{t.trigger}{' ' + t.label if t.label else ''}--> {t.dest}"
            for t in TRANSITIONS]
    rows += [f"{'paused':24s} --resume--> {dest}" for dest in RESUMABLE]
    rows += [f"{'held':24s} --resume--> {dest}" for dest in RECOVERABLE]
    return "\n".join(rows) + "\n"


def readme_block() -> str:
    """The README's block: the diagram in a mermaid fence, then the error policy."""
    return (f"{BEGIN}\n```mermaid\n{mermaid()}```\n\n{policy_table()}{END}\n")


__all__ = ["BEGIN", "END", "mermaid", "policy_table", "readme_block", "transition_table"]
