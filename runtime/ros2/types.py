"""Typestore type names -> the classes rosidl generated for the same types.

Topics cross as raw CDR and need the class only to create the endpoint; services (and
the services of actions) cross as rclpy messages, converted with rclpy's C serializer.
``pkg/msg/Name`` is ``pkg.msg.Name``; a service's ``pkg/srv/Name`` is ``pkg.srv.Name``;
the parts rosidl composes for services and actions (``Name_Request``,
``Reach_SendGoal_Response``, ``Reach_FeedbackMessage``...) live in the module that
defines ``Name`` (``pkg.action._reach``).
"""

from __future__ import annotations

import functools
import importlib
import sys
from typing import Any

from runtime.errors import RuntimeApiError

__all__ = ["MissingRosPackageError", "rclpy_type", "service_type_of"]


class MissingRosPackageError(RuntimeApiError):
    """A type's ROS 2 package is not built into this Python."""


@functools.cache
def rclpy_type(type_name: str) -> Any:
    """The rosidl class of a message or service ``pkg/kind/Name``."""
    pkg, kind, name = type_name.split("/")
    try:
        module = importlib.import_module(f"{pkg}.{kind}")
    except ImportError as exc:
        hint = (" (run `make ros-interfaces`)" if pkg in ("px4_msgs", "quadmission_interfaces")
                else "")
        raise MissingRosPackageError(
            f"{type_name}: ROS 2 package {pkg!r} is not importable{hint}: {exc}") from None
    found = getattr(module, name, None)
    if found is None:  # a composed part: Base_Request, Base_SendGoal_Response...
        base = getattr(module, name.split("_", 1)[0], None)
        if base is not None:
            found = getattr(sys.modules[base.__module__], name, None)
    if found is None:
        raise MissingRosPackageError(f"{type_name}: {pkg}.{kind} has no {name}; rebuild the "
                                     "interfaces (`make ros-interfaces`)")
    return found


def service_type_of(part_type_name: str) -> Any:
    """The service class of its request or response type (``.../Name_Request``)."""
    for suffix in ("_Request", "_Response"):
        if part_type_name.endswith(suffix):
            return rclpy_type(part_type_name[: -len(suffix)])
    raise RuntimeApiError(f"{part_type_name} is not a service request or response type")
