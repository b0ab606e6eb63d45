"""Errors raised by the quadmission app layer (scenarios, experiments)."""

from __future__ import annotations


class QuadmissionError(Exception):
    """Base class for quadmission errors."""


class ScenarioRefused(QuadmissionError, ValueError):
    """A scenario that cannot be run as asked in this arena; the message says why."""


class SquareDoesNotFit(ScenarioRefused):
    """No square flight keeps clear of the arena's walls and obstacles."""


class OptionsError(QuadmissionError, ValueError):
    """Scenario options that contradict each other or are out of range."""
