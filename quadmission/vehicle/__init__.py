"""The simulated vehicle on the wall clock (``quadmission vehicle``) and its ground truth."""

from quadmission.vehicle.lag import LagMonitor
from quadmission.vehicle.truth import VehicleTruth, load_truth

__all__ = ["LagMonitor", "VehicleTruth", "load_truth"]
