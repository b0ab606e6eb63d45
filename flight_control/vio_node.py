"""Forwards the visual odometry to the flight controller, as the paper's ORB-SLAM2 did.

The measurement comes from the simulator on ``/sim/vision/pose`` (map frame, sample
time in the stamp); this companion-side node passes it to ``/fcu/vision``, which the
FCU bridge sends to the FCU's estimator with its sample time. Setting the ``enabled``
parameter to false cuts the stream, as a lost tracking would.
"""

from __future__ import annotations

from typing import Any

from interfaces import graph
from runtime import Node, Parameter
from runtime.parameters import SetParametersResult


class VioNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("vio", **kwargs)
        self.enabled = bool(self.declare_parameter("enabled", True).value)
        self.forwarded = 0
        out, measured = graph.FCU_VISION, graph.SIM_VISION_POSE
        self.pub = self.create_publisher(out.type, out.name, out.qos)
        self.create_subscription(measured.type, measured.name, self._forward,
                                 measured.subscriber_qos)
        self.add_on_set_parameters_callback(self._on_set)

    def _on_set(self, params: list[Parameter]) -> SetParametersResult:
        for p in params:
            if p.name == "enabled":
                self.enabled = bool(p.value)
        return SetParametersResult(True)

    def set_tracking(self, enabled: bool) -> None:
        """Cut (False) or restore (True) the stream."""
        (result,) = self.set_parameters([Parameter("enabled", self.get_parameter(
            "enabled").type, enabled)])
        if not result.successful:
            raise ValueError(result.reason)

    def _forward(self, msg: Any) -> None:
        if self.enabled:
            self.pub.publish(msg)
            self.forwarded += 1
