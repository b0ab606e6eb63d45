"""The rclpy side of tests/interfaces/test_ros_packages.py, run as a separate process.

Reads a JSON list of requests on stdin and writes a JSON list of answers on stdout:
``{"type": "pkg/msg/Name", "cdr": "<hex>"}`` -> ``{"value": <fields as plain JSON>}``
(deserialized with rclpy into the built type), and ``{"type": ..., "value": {...}}`` ->
``{"cdr": "<hex>"}`` (a built-type message made from those field values, serialized with
rclpy); ``{"error": "..."}`` when rclpy cannot. Type names as rosbags spells them
(``pkg/srv/Name_Request``, ``pkg/action/Name_Goal``). Imports nothing from this repository.
"""

from __future__ import annotations

import array
import importlib
import json
import sys
from typing import Any

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message
from rosidl_parser.definition import AbstractNestedType, NamespacedType

PARTS = ("Request", "Response", "Goal", "Result", "Feedback")


def ros_class(name: str) -> Any:
    """The generated class for ``pkg/kind/Name``, ``pkg/kind/Name_Part`` or an action's
    composed ``Name_SendGoal_Request``, ``Name_GetResult_Response``, ``Name_FeedbackMessage``."""
    pkg, kind, cls = name.split("/")
    module = importlib.import_module(f"{pkg}.{kind}")
    base, _, part = cls.partition("_")
    if part in PARTS:
        return getattr(getattr(module, base), part)
    if part == "FeedbackMessage":
        return getattr(module, base).Impl.FeedbackMessage
    service, _, side = part.partition("_")
    if service in ("SendGoal", "GetResult"):
        return getattr(getattr(getattr(module, base).Impl, f"{service}Service"), side)
    return getattr(module, cls)


def _namespaced(slot: NamespacedType) -> Any:
    return ros_class("/".join([*slot.namespaces, slot.name]))


def to_plain(value: Any) -> Any:
    if hasattr(value, "get_fields_and_field_types"):
        return {f: to_plain(getattr(value, f)) for f in value.get_fields_and_field_types()}
    if isinstance(value, (np.ndarray, array.array)):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [to_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def from_plain(cls: Any, plain: dict[str, Any]) -> Any:
    msg = cls()
    for field, slot in zip(cls.get_fields_and_field_types(), cls.SLOT_TYPES, strict=True):
        value = plain[field]
        if isinstance(slot, NamespacedType):
            value = from_plain(_namespaced(slot), value)
        elif isinstance(slot, AbstractNestedType) and isinstance(slot.value_type, NamespacedType):
            value = [from_plain(_namespaced(slot.value_type), v) for v in value]
        setattr(msg, field, value)
    return msg


def answer(request: dict[str, Any]) -> dict[str, Any]:
    """The answer to one request, or ``{"error": ...}`` saying why rclpy could not."""
    try:
        cls = ros_class(request["type"])
        if "cdr" in request:
            return {"value": to_plain(deserialize_message(bytes.fromhex(request["cdr"]), cls))}
        return {"cdr": serialize_message(from_plain(cls, request["value"])).hex()}
    except Exception as exc:  # reported per type, so one bad type fails one test
        return {"error": f"{type(exc).__name__}: {exc}"}


if __name__ == "__main__":
    json.dump([answer(r) for r in json.load(sys.stdin)], sys.stdout)
