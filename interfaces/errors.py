"""Errors raised by the interfaces package."""

from __future__ import annotations


class InterfaceError(Exception):
    """Base class for interface (message type) errors."""


class UnknownTypeError(InterfaceError, KeyError):
    """A message, service or action name that is not registered."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else "unknown type"


class DefinitionError(InterfaceError):
    """A .msg/.srv/.action file that cannot be parsed."""


class MessageError(InterfaceError, ValueError):
    """A message instance that does not match its type (bad field, value, length)."""


class RosBuildError(InterfaceError):
    """The ROS 2 interface packages could not be built: names what is missing or failed."""
