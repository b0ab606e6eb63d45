"""The mission machine as the page draws it: every nested state and every transition,
from :mod:`fsm.mission_table` (one fact, one place). The page lights the state
``/mission/state`` names (``mission.pad.land`` lights ``mission``, ``mission.pad`` and
``mission.pad.land``) and lists the transitions that leave it. Pure module."""

from __future__ import annotations

from typing import Any

from fsm.mission_table import RESUMABLE, SEPARATOR, TRANSITIONS, walk


def diagram() -> dict[str, Any]:
    """``{"states": [{name, label, depth, doc, terminal, composite}], "transitions":
    [{source, dest, trigger, label}]}``, states parents-first."""
    states = [{"name": name, "label": spec.name, "depth": name.count(SEPARATOR),
               "doc": spec.doc, "terminal": spec.terminal, "composite": bool(spec.children)}
              for name, spec in walk()]
    transitions = [{"source": t.source, "dest": t.dest, "trigger": t.trigger,
                    "label": t.label} for t in TRANSITIONS]
    transitions += [{"source": "paused", "dest": dest, "trigger": "resume", "label": ""}
                    for dest in RESUMABLE]
    return {"states": states, "transitions": transitions}


__all__ = ["diagram"]
