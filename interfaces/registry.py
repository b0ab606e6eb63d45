"""Load .msg/.srv/.action files into a rosbags typestore on top of ROS 2 Jazzy.

The interface files under ``interfaces/<package>/{msg,srv,action}/`` are the source of
truth. A service ``pkg/srv/Name`` becomes the message types ``pkg/srv/Name_Request`` and
``pkg/srv/Name_Response``; an action ``pkg/action/Name`` becomes ``Name_Goal``,
``Name_Result``, ``Name_Feedback`` and the ROS 2 composed types ``Name_SendGoal_Request``,
``Name_SendGoal_Response``, ``Name_GetResult_Request``, ``Name_GetResult_Response`` and
``Name_FeedbackMessage``, exactly as rosidl generates them.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from interfaces.errors import DefinitionError

INTERFACE_ROOT = Path(__file__).resolve().parent

UUID = "unique_identifier_msgs/msg/UUID"
TIME = "builtin_interfaces/msg/Time"
GOAL_INFO = "action_msgs/msg/GoalInfo"
CANCEL_GOAL = "action_msgs/srv/CancelGoal"

Typedefs = dict[str, tuple[list[Any], list[Any]]]


@dataclass(frozen=True)
class InterfaceFile:
    """One interface definition file found on disk."""

    package: str
    kind: str  # "msg", "srv" or "action"
    name: str
    path: Path

    @property
    def full_name(self) -> str:
        return f"{self.package}/{self.kind}/{self.name}"


def iter_interface_files(root: Path = INTERFACE_ROOT) -> Iterator[InterfaceFile]:
    """Yield every .msg/.srv/.action file under ``root/<package>/<kind>/``, sorted."""
    for kind in ("msg", "srv", "action"):
        for path in sorted(root.glob(f"*/{kind}/*.{kind}")):
            yield InterfaceFile(path.parent.parent.name, kind, path.stem, path)


def _sections(text: str, expected: int, what: str) -> list[str]:
    parts: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            parts.append([])
        else:
            parts[-1].append(line)
    if len(parts) != expected:
        raise DefinitionError(
            f"{what}: expected {expected} sections separated by '---', found {len(parts)}"
        )
    return ["\n".join(p) + "\n" for p in parts]


def _parse_section(text: str, package: str, full_name: str) -> Typedefs:
    """Parse one msg-syntax section; relative type names resolve to ``package/msg``."""
    probe = f"{package}/msg/{full_name.rsplit('/', 1)[-1]}"
    try:
        parsed = get_types_from_msg(text, probe)
    except Exception as exc:  # rosbags raises several parser errors
        raise DefinitionError(f"{full_name}: {exc}") from None
    return {full_name: parsed[probe]}


def _name(typename: str) -> tuple[Nodetype, str]:
    return (Nodetype.NAME, typename)


def _base(typename: str) -> tuple[Nodetype, tuple[str, int]]:
    return (Nodetype.BASE, (typename, 0))


def action_typedefs(base: str, goal: Typedefs, result: Typedefs, feedback: Typedefs) -> Typedefs:
    """The composed ROS 2 action types around the goal, result and feedback."""
    defs: Typedefs = {**goal, **result, **feedback}
    defs[f"{base}_SendGoal_Request"] = (
        [],
        [("goal_id", _name(UUID)), ("goal", _name(f"{base}_Goal"))],
    )
    defs[f"{base}_SendGoal_Response"] = ([], [("accepted", _base("bool")), ("stamp", _name(TIME))])
    defs[f"{base}_GetResult_Request"] = ([], [("goal_id", _name(UUID))])
    defs[f"{base}_GetResult_Response"] = (
        [],
        [("status", _base("int8")), ("result", _name(f"{base}_Result"))],
    )
    defs[f"{base}_FeedbackMessage"] = (
        [],
        [("goal_id", _name(UUID)), ("feedback", _name(f"{base}_Feedback"))],
    )
    return defs


def cancel_goal_typedefs() -> Typedefs:
    """action_msgs/srv/CancelGoal, which the rosbags Jazzy store does not carry."""
    return {
        f"{CANCEL_GOAL}_Request": ([], [("goal_info", _name(GOAL_INFO))]),
        f"{CANCEL_GOAL}_Response": (
            [
                ("ERROR_NONE", "int8", 0),
                ("ERROR_REJECTED", "int8", 1),
                ("ERROR_UNKNOWN_GOAL_ID", "int8", 2),
                ("ERROR_GOAL_TERMINATED", "int8", 3),
            ],
            [
                ("return_code", _base("int8")),
                ("goals_canceling", (Nodetype.SEQUENCE, (_name(GOAL_INFO), 0))),
            ],
        ),
    }


def typedefs_of(item: InterfaceFile) -> Typedefs:
    """Parse one interface file into rosbags type definitions."""
    text = item.path.read_text(encoding="utf-8")
    full = item.full_name
    if item.kind == "msg":
        return _parse_section(text, item.package, full)
    if item.kind == "srv":
        req, rep = _sections(text, 2, str(item.path))
        return {
            **_parse_section(req, item.package, f"{full}_Request"),
            **_parse_section(rep, item.package, f"{full}_Response"),
        }
    goal, result, feedback = _sections(text, 3, str(item.path))
    return action_typedefs(
        full,
        _parse_section(goal, item.package, f"{full}_Goal"),
        _parse_section(result, item.package, f"{full}_Result"),
        _parse_section(feedback, item.package, f"{full}_Feedback"),
    )


def build_typestore(root: Path = INTERFACE_ROOT) -> Any:
    """A ROS 2 Jazzy typestore with every interface file under ``root`` registered."""
    store = get_typestore(Stores.ROS2_JAZZY)
    defs: Typedefs = cancel_goal_typedefs()
    for item in iter_interface_files(root):
        defs.update(typedefs_of(item))
    try:
        store.register(defs)
    except Exception as exc:
        raise DefinitionError(f"cannot register interface types: {exc}") from None
    return store
