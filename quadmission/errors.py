"""Errors raised by the app layer (experiments, scenarios): each names what was wrong."""

from __future__ import annotations


class QuadmissionError(Exception):
    """Base class for the app layer's errors."""


class ExperimentError(QuadmissionError, ValueError):
    """An experiment that cannot give its figures with the settings asked for."""


class ScenarioRefused(QuadmissionError, ValueError):
    """A scenario that cannot be run as asked in this arena; the message says why."""


class SquareDoesNotFit(ScenarioRefused):
    """No square flight keeps clear of the arena's walls and obstacles."""


class OptionsError(QuadmissionError, ValueError):
    """Scenario options that contradict each other or are out of range."""


class CampaignError(QuadmissionError, ValueError):
    """A campaign file that cannot be run; the message names the file, the key and the
    bad value."""
