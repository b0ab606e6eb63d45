"""The flight-control layer: the FCU bridge (frames, clocks), flight-control services, VIO."""

from flight_control.bridge_node import FcuBridgeNode
from flight_control.flight_control_node import FlightControlNode
from flight_control.timesync import ESTIMATORS, make_estimator
from flight_control.vio_node import VioNode

__all__ = [
    "ESTIMATORS",
    "FcuBridgeNode",
    "FlightControlNode",
    "VioNode",
    "make_estimator",
]
