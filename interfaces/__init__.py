"""Message, service and action types: .msg/.srv/.action files in a rosbags typestore."""

from interfaces.api import (
    ActionType,
    ServiceType,
    cancel_goal_service,
    deserialize,
    get_action,
    get_message,
    get_service,
    messages_equal,
    new,
    registered_types,
    serialize,
    type_name,
    typestore,
    validate,
)
from interfaces.errors import DefinitionError, InterfaceError, MessageError, UnknownTypeError

__all__ = [
    "ActionType",
    "DefinitionError",
    "InterfaceError",
    "MessageError",
    "ServiceType",
    "UnknownTypeError",
    "cancel_goal_service",
    "deserialize",
    "get_action",
    "get_message",
    "get_service",
    "messages_equal",
    "new",
    "registered_types",
    "serialize",
    "type_name",
    "typestore",
    "validate",
]
