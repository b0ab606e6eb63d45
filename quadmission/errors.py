"""Errors raised by the app layer (experiments, scenarios): each names what was wrong."""

from __future__ import annotations


class QuadmissionError(Exception):
    """Base class for the app layer's errors."""


class ExperimentError(QuadmissionError, ValueError):
    """An experiment that cannot give its figures with the settings asked for."""
