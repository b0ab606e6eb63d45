"""Our nodes' parameters declared on their rcl nodes, so ROS 2 tools list, read and set them.

The node of ours stays the owner, and the two copies stay in step both ways:

- a value set from outside (``ros2 param set``, an rclpy parameter client) is validated by
  our node's ``set_parameters`` (ranges, read-only, on-set callbacks), and the rcl node
  takes it only if ours did;
- a value our node sets itself (a switch it flips, a setting it adapts) is written to the
  rcl node, so an outside client reads the value our node holds.

Either way the rcl node stores the value through rclpy's own ``set_parameters``, which
publishes the change on ``/parameter_events`` (rcl_interfaces/msg/ParameterEvent: the
node's name, the new, changed and deleted parameters, a stamp), once per change, as every
rclpy node does.
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


def _rcl_parameter(param: Parameter) -> RclParameter:
    value = param.value
    return RclParameter(param.name, _RCL_TYPE[param.type],
                        list(value) if isinstance(value, tuple | list) else value)


class _Mirror:
    """Keeps ``rcl_node``'s copies of ``node``'s parameters in step with ``node``'s."""

    def __init__(self, node: Node, rcl_node: RclNode) -> None:
        self._node = node
        self._rcl_node = rcl_node
        self._from_outside: set[str] = set()  # names an outside set is giving our node
        self._writing_back = False  # our node's change is being written to the rcl node

    def on_rcl_set(self, params: list[RclParameter]) -> RclResult:
        """The rcl node is about to take ``params``: from outside, only if our node takes
        them; our node's own change, written back, as it is."""
        if self._writing_back:
            return RclResult(successful=True)
        for p in params:
            known = self._node.get_parameters_by_prefix("").get(p.name)
            if known is None:
                continue  # rclpy's own (use_sim_time...)
            self._from_outside.add(p.name)
            try:
                result = self._node.set_parameters([Parameter(p.name, known.type, p.value)])[0]
            finally:
                self._from_outside.discard(p.name)
            if not result.successful:
                return RclResult(successful=False, reason=result.reason)
        return RclResult(successful=True)

    def on_our_set(self, params: list[Parameter]) -> None:
        """Our node set ``params``: write those it set itself to the rcl node (one from
        outside is stored there by the rclpy set that brought it)."""
        own = [p for p in params if p.name not in self._from_outside]
        if not own:
            return
        self._writing_back = True
        try:
            results = self._rcl_node.set_parameters([_rcl_parameter(p) for p in own])
        finally:
            self._writing_back = False
        for p, result in zip(own, results, strict=True):
            if not result.successful:
                self._node.get_logger().error(
                    f"parameter {p.name} = {p.value!r} not shown to ROS 2 tools: {result.reason}")


def mirror_parameters(node: Node, rcl_node: RclNode) -> None:
    """Declare every parameter of ``node`` on ``rcl_node``, and keep them in step both ways."""
    ours = node.get_parameters_by_prefix("")
    for name, param in sorted(ours.items()):
        if rcl_node.has_parameter(name):
            continue
        rcl_node.declare_parameter(
            name, _rcl_value(param),
            RclDescriptor(type=_RCL_TYPE[param.type].value, description=f"{param.type.value}"))
    mirror = _Mirror(node, rcl_node)
    rcl_node.add_on_set_parameters_callback(mirror.on_rcl_set)
    node.add_post_set_parameters_callback(mirror.on_our_set)
