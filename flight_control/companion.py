"""The companion computer's flight stack on top of a software-in-the-loop FCU.

:func:`start_companion` adds the FCU bridge and the visual-odometry forwarder to a
:class:`~sim.fcu.sitl.Sitl`'s executor (the flight-control node and the mission come on
top of them). Tests and scenarios use it; over DDS the same nodes run as processes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from flight_control.bridge_node import FcuBridgeNode
from flight_control.vio_node import VioNode

if TYPE_CHECKING:
    from sim.fcu.sitl import Sitl


@dataclass
class Companion:
    bridge: FcuBridgeNode
    vio: VioNode


def start_companion(sitl: Sitl, **bridge_overrides: Any) -> Companion:
    """Bridge and VIO forwarder in ``sitl``'s executor, with config/ parameters."""
    context = sitl.executor.context
    bridge = FcuBridgeNode(context=context, parameter_overrides=bridge_overrides)
    vio = VioNode(context=context)
    for node in (bridge, vio):
        sitl.executor.add_node(node)
    return Companion(bridge, vio)
