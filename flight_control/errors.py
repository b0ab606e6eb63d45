"""Errors raised by the flight_control package."""

from __future__ import annotations

from runtime.errors import ParameterError


class FlightControlError(Exception):
    """Base class for flight_control errors."""


class UnknownEstimatorError(FlightControlError, LookupError):
    """A time-sync estimator name that is not in the registry."""


class TimesyncParameterError(FlightControlError, ParameterError):
    """A time-sync estimator or trace parameter that is unknown, mistyped or out of range."""
