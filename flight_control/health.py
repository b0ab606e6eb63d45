"""HealthReport messages: one module's health, as every companion node publishes it on
``/<node>/health``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import interfaces

MODULE_HEALTH: Any = interfaces.get_message("quadmission_interfaces/msg/ModuleHealth")


def health_report(name: str, level: int, message: str, values: Mapping[str, object],
                  stamp: Any) -> Any:
    """A HealthReport of one module; booleans as ``true``/``false`` like flight_control."""
    module = interfaces.new(
        "quadmission_interfaces/msg/ModuleHealth", name=name, level=int(level), message=message,
        last_update=stamp,
        values=[interfaces.new("diagnostic_msgs/msg/KeyValue", key=k,
                               value=str(v).lower() if isinstance(v, bool) else str(v))
                for k, v in values.items()])
    return interfaces.new("quadmission_interfaces/msg/HealthReport",
                          header=interfaces.new("std_msgs/msg/Header", stamp=stamp),
                          level=int(level), modules=[module])


__all__ = ["MODULE_HEALTH", "health_report"]
