"""Errors raised by the node runtime."""

from __future__ import annotations


class RuntimeApiError(Exception):
    """Base class for runtime errors."""


class InvalidNameError(RuntimeApiError, ValueError):
    """An invalid topic, service, action or node name."""


class TopicTypeError(RuntimeApiError, TypeError):
    """A topic used with two different message types, or a message of the wrong type."""


class ParameterError(RuntimeApiError, ValueError):
    """A parameter that is unknown, missing, of the wrong type or out of range."""


class ClockError(RuntimeApiError, ValueError):
    """Time asked to run backwards, or a period that is not positive."""


class FutureError(RuntimeApiError):
    """A future's result asked for before it is done, or set twice."""


class LaunchError(RuntimeApiError):
    """A launch description that names a missing factory or a bad node entry."""

