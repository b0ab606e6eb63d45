"""Our nodes' parameters declared on their rcl nodes, so ROS 2 tools list, read and set them.

The node of ours stays the owner, and the two copies stay in step both ways:

- a parameter our node declares, before or after it is mirrored (a node may declare one
  late, while it runs), is declared on the rcl node too: our node's post-set callbacks hear
  declarations as rclpy's do;
- a value set from outside (``ros2 param set``, an rclpy parameter client) is validated by
  our node's ``set_parameters`` (ranges, read-only, on-set callbacks), and the rcl node
  takes it only if ours did;
- a value our node sets itself (a switch it flips, a setting it adapts) is written to the
  rcl node, so an outside client reads the value our node holds.

Either way the rcl node stores the value through rclpy's own ``declare_parameter`` or
``set_parameters``, which publishes it on ``/parameter_events``
(rcl_interfaces/msg/ParameterEvent: the node's name, the new, changed and deleted
parameters, a stamp), once per declaration or change, as every rclpy node does.
"""

from __future__ import annotations

from rcl_interfaces.msg import ParameterDescriptor as RclDescriptor
from rcl_interfaces.msg import SetParametersResult as RclResult
from rclpy.exceptions import ParameterException
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


def _rcl_parameter(param: Parameter) -> RclParameter:
    """``param`` as rclpy's Parameter of the same type (an array as a list)."""
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
        """Our node declared or set ``params``: declare on the rcl node those it lacks, and
        write there those our node set itself (one from outside is stored there by the
        rclpy set that brought it)."""
        for p in params:
            if p.name in self._from_outside:
                continue
            refused = self._write_back(p)
            if refused is not None:
                self._node.get_logger().error(
                    f"parameter {p.name} = {p.value!r} not shown to ROS 2 tools: {refused}")

    def _write_back(self, param: Parameter) -> str | None:
        """Declare or set ``param`` on the rcl node; why it was refused, or None."""
        rcl = _rcl_parameter(param)
        self._writing_back = True  # rclpy's declare runs the on-set callbacks too
        try:
            if self._rcl_node.has_parameter(rcl.name):
                (result,) = self._rcl_node.set_parameters([rcl])
                return None if result.successful else str(result.reason)
            # rclpy takes a declared type from the default, and an empty list has none:
            # an empty array is declared by its type alone (typed, unset)
            default = rcl.type_ if rcl.value == [] else rcl.value
            self._rcl_node.declare_parameter(rcl.name, default, RclDescriptor(
                type=rcl.type_.value, description=param.type.value))
            return None
        except ParameterException as e:
            return str(e)
        finally:
            self._writing_back = False


def mirror_parameters(node: Node, rcl_node: RclNode) -> None:
    """Declare every parameter of ``node`` on ``rcl_node``, those it declares later too, and
    keep them in step both ways. Once per node: a second call would mirror every change
    twice (:meth:`runtime.ros2.transport.Ros2Transport.mirror_parameters` calls it once)."""
    mirror = _Mirror(node, rcl_node)
    mirror.on_our_set([p for _, p in sorted(node.get_parameters_by_prefix("").items())
                       if not rcl_node.has_parameter(p.name)])
    rcl_node.add_on_set_parameters_callback(mirror.on_rcl_set)
    node.add_post_set_parameters_callback(mirror.on_our_set)
