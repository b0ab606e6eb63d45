"""ROS 2 wire types for Cyclone DDS, built at runtime from the typestore.

Every message type of :mod:`interfaces` becomes a ``cyclonedds`` ``IdlStruct`` named as
rmw_cyclonedds names it (``std_msgs/msg/String`` -> ``std_msgs::msg::dds_::String_``),
``@final`` (ROS 2 types are final structs) and serialised as XCDR1, so its CDR bytes are
those rosbags writes for the same message (a test checks this field type by field type).
A DDS name comes from a ROS name as the ROS 2 design article says: topics ``rt/<name>``,
service requests ``rq/<name>Request``, replies ``rr/<name>Reply``.
"""

from __future__ import annotations

import functools
from typing import Any

from cyclonedds.idl import IdlStruct, make_idl_struct, types
from cyclonedds.idl.annotations import final
from rosbags.interfaces import Nodetype

import interfaces
from runtime.transport import EndpointKind

__all__ = ["dds_topic_name", "dds_type_name", "idl_struct", "type_hash"]

_BASE: dict[str, Any] = {
    "bool": bool,
    "byte": types.uint8,
    "char": types.uint8,
    "int8": types.int8,
    "uint8": types.uint8,
    "int16": types.int16,
    "uint16": types.uint16,
    "int32": types.int32,
    "uint32": types.uint32,
    "int64": types.int64,
    "uint64": types.uint64,
    "float32": types.float32,
    "float64": types.float64,
}
_PREFIX = {EndpointKind.TOPIC: "rt", EndpointKind.REQUEST: "rq", EndpointKind.REPLY: "rr"}
_SUFFIX = {EndpointKind.TOPIC: "", EndpointKind.REQUEST: "Request", EndpointKind.REPLY: "Reply"}


def dds_type_name(type_name: str) -> str:
    """``pkg/msg/Type`` -> ``pkg::msg::dds_::Type_`` (rmw_cyclonedds' convention)."""
    pkg, kind, name = interfaces.type_name(interfaces.get_message(type_name)).split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def dds_topic_name(ros_name: str, kind: EndpointKind) -> str:
    """A resolved ROS name (``/fcu/odometry``) as a DDS topic name (``rt/fcu/odometry``)."""
    return f"{_PREFIX[kind]}{ros_name}{_SUFFIX[kind]}"


def type_hash(type_name: str) -> str:
    """The RIHS01 type hash ROS 2 Jazzy puts in an endpoint's USER_DATA (rosbags computes it)."""
    return str(interfaces.typestore().hash_rihs01(interfaces.type_name(
        interfaces.get_message(type_name))))


def _field_type(node: tuple[Any, Any]) -> Any:
    kind, arg = node
    if kind == Nodetype.BASE:
        base, bound = arg
        if base == "string":
            return types.bounded_str[bound] if bound else str  # type: ignore[misc]
        if base == "wstring":
            raise NotImplementedError("wstring fields are not supported over DDS")
        return _BASE[base]
    if kind == Nodetype.NAME:
        return idl_struct(str(arg))
    sub, length = arg
    inner = _field_type(sub)
    if kind == Nodetype.ARRAY:
        return types.array[inner, length]  # type: ignore[misc]
    return (types.sequence[inner, length] if length  # type: ignore[misc]
            else types.sequence[inner])  # type: ignore[misc]


#: The fields rmw_cyclonedds puts in front of a service request or reply: the client's
#: 64-bit GUID and the sequence number (its ``cdds_request_header_t``).
REQUEST_HEADER_FIELDS: dict[str, Any] = {"request_guid_": types.uint64,
                                         "request_seq_": types.int64}


@functools.cache
def idl_struct(type_name: str, request_header: bool = False) -> type[IdlStruct]:
    """The ``@final`` IdlStruct for a typestore message type (built once, then cached).

    ``request_header=True`` gives the type a service sample travels as: the request id
    fields first, then the message's (the same bytes rmw_cyclonedds writes)."""
    full = interfaces.type_name(interfaces.get_message(type_name))
    _, fields = interfaces.typestore().fielddefs[full]
    name = full.rsplit("/", 1)[1]
    # An empty ROS message carries one uint8, as rosidl generates it.
    spec = {fname: _field_type(node) for fname, node in fields} or {
        "structure_needs_at_least_one_member": types.uint8}
    if request_header:
        spec = REQUEST_HEADER_FIELDS | spec
    cls = make_idl_struct(f"{name}_", dds_type_name(full), spec)
    final(cls)
    return cls
