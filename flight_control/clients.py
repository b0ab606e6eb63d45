"""What a client of the flight-control layer does the same way everywhere.

:func:`arm` calls ``/flight_control/arm`` until it succeeds or the attempts run out: the
commander refuses to arm while its checks settle (the estimate, the link), so the mission
and the square's pilot both retry, a second apart, five times by default: on a starved CPU
the bridge's time sync can reset and hold the visual odometry back until it converges
again, and the FCU's position estimate is then invalid for a second or two, long enough
for several refusals in a row.
"""

from __future__ import annotations

from typing import Any

import interfaces
from flight_control.flight_control_node import ARM
from interfaces import graph
from runtime import Node

ARM_RETRY_S = 1.0  # s between arming attempts


def arm_client(node: Node) -> Any:
    """A client of the flight-control layer's arm service."""
    return node.create_client(ARM, graph.ARM.name)


async def arm(node: Node, client: Any, attempts: int) -> str | None:
    """Arm through ``client``, trying ``attempts`` times: None once armed, else the last
    refusal's message."""
    message = "no attempt"
    for attempt in range(attempts):
        if attempt:
            await node.sleep(ARM_RETRY_S)
        response = await client.call_async(interfaces.new(ARM.Request))
        if response.success:
            return None
        message = str(response.message)
    return message


__all__ = ["ARM_RETRY_S", "arm", "arm_client"]
