"""Operator commands: what the page may send, checked before anything is published.

A command is ``{"command": NAME, "sequence": [pad ids], "reason": text}`` in JSON; NAME
is one of :class:`Verb`. A landing sequence is a non-empty list of distinct pad ids,
known pads when the field layout is known. :func:`parse_command` raises
:class:`~ground_station.errors.CommandError` naming what is wrong.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from enum import Enum
from typing import Any

from ground_station.errors import CommandError

MAX_REASON_CHARS = 200


class Verb(Enum):
    """Operator commands, with MissionCommand's COMMAND_* name each maps to."""

    START = "start"
    PAUSE = "pause"
    RESUME = "resume"
    ABORT = "abort"
    RETURN_HOME = "return_home"
    SEQUENCE = "sequence"

    @property
    def constant(self) -> str:
        return f"COMMAND_{self.name}"


@dataclass(frozen=True)
class OperatorCommand:
    verb: Verb
    sequence: tuple[int, ...] = ()
    reason: str = ""


def parse_command(payload: Any, pad_ids: Collection[int] = ()) -> OperatorCommand:
    """An :class:`OperatorCommand` from decoded JSON; CommandError says what is wrong."""
    if not isinstance(payload, dict):
        raise CommandError("a command is a JSON object: {\"command\": ..., ...}")
    unknown = sorted(set(payload) - {"command", "sequence", "reason"})
    if unknown:
        raise CommandError(f"unknown key {unknown[0]!r}; allowed: command, sequence, reason")
    name = payload.get("command")
    try:
        verb = Verb(name)
    except ValueError:
        raise CommandError(f"unknown command {name!r}; one of: "
                           + ", ".join(v.value for v in Verb)) from None
    reason = payload.get("reason", "")
    if not isinstance(reason, str) or len(reason) > MAX_REASON_CHARS:
        raise CommandError(f"reason must be text of at most {MAX_REASON_CHARS} characters")
    raw = payload.get("sequence", [])
    if verb is not Verb.SEQUENCE:
        if raw:
            raise CommandError(f"{verb.value} takes no sequence")
        return OperatorCommand(verb, (), reason)
    if not isinstance(raw, list) or not raw:
        raise CommandError("sequence must be a non-empty list of pad ids")
    if not all(isinstance(p, int) and not isinstance(p, bool) for p in raw):
        raise CommandError(f"sequence must hold integer pad ids, got {raw!r}")
    if len(set(raw)) != len(raw):
        raise CommandError(f"sequence {raw} visits a pad twice")
    bad = [p for p in raw if (p not in pad_ids if pad_ids else not 1 <= p <= 65535)]
    if bad:
        known = f"; the pads are {sorted(pad_ids)}" if pad_ids else ""
        raise CommandError(f"no pad {bad[0]} in the field{known}")
    return OperatorCommand(verb, tuple(raw), reason)


__all__ = ["MAX_REASON_CHARS", "OperatorCommand", "Verb", "parse_command"]
