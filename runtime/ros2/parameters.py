"""Our nodes' parameters declared on their rcl nodes, so ROS 2 tools list, read and set them.

The node of ours stays the owner: a value set from outside (``ros2 param set``, an rclpy
parameter client) is validated by our node's ``set_parameters`` (ranges, read-only,
on-set callbacks) and the rcl node takes it only if ours did.
"""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import ParameterDescriptor as RclDescriptor
from rcl_interfaces.msg import SetParametersResult as RclResult
from rclpy.node import Node as RclNode
from rclpy.parameter import Parameter as RclParameter

from runtime.node import Node
from runtime.parameters import Parameter, ParameterType

__all__ = ["mirror_parameters"]

_RCL_TYPE = {
    ParameterType.BOOL: RclParameter.Type.BOOL,
    ParameterType.INTEGER: RclParameter.Type.INTEGER,
    ParameterType.DOUBLE: RclParameter.Type.DOUBLE,
    ParameterType.STRING: RclParameter.Type.STRING,
    ParameterType.BOOL_ARRAY: RclParameter.Type.BOOL_ARRAY,
    ParameterType.INTEGER_ARRAY: RclParameter.Type.INTEGER_ARRAY,
    ParameterType.DOUBLE_ARRAY: RclParameter.Type.DOUBLE_ARRAY,
    ParameterType.STRING_ARRAY: RclParameter.Type.STRING_ARRAY,
}


def _rcl_value(param: Parameter) -> Any:
    value = param.value
    if isinstance(value, tuple | list):
        return list(value) if value else _RCL_TYPE[param.type]  # empty: typed, unset
    return value


def mirror_parameters(node: Node, rcl_node: RclNode) -> None:
    """Declare every parameter of ``node`` on ``rcl_node``; route sets through ``node``."""
    ours = node.get_parameters_by_prefix("")
    for name, param in sorted(ours.items()):
        if rcl_node.has_parameter(name):
            continue
        rcl_node.declare_parameter(
            name, _rcl_value(param),
            RclDescriptor(type=_RCL_TYPE[param.type].value, description=f"{param.type.value}"))

    def on_set(params: list[RclParameter]) -> RclResult:
        for p in params:
            known = node.get_parameters_by_prefix("").get(p.name)
            if known is None:
                continue  # rclpy's own (use_sim_time...)
            result = node.set_parameters([Parameter(p.name, known.type, p.value)])[0]
            if not result.successful:
                return RclResult(successful=False, reason=result.reason)
        return RclResult(successful=True)

    rcl_node.add_on_set_parameters_callback(on_set)
