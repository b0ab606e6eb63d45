"""The flight-control layer: the FCU bridge (frames, clocks), flight-control services, VIO.

The nodes are imported when first asked for, so a pure module of this package
(``flight_control.frames``, ``px4_messages``...) can be imported without the runtime.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "ESTIMATORS",
    "FcuBridgeNode",
    "FlightControlNode",
    "VioNode",
    "make_estimator",
]

_WHERE = {
    "ESTIMATORS": "flight_control.timesync",
    "FcuBridgeNode": "flight_control.bridge_node",
    "FlightControlNode": "flight_control.flight_control_node",
    "VioNode": "flight_control.vio_node",
    "make_estimator": "flight_control.timesync",
}


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module 'flight_control' has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name]), name)
