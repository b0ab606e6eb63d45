"""Errors raised by the node runtime."""

from __future__ import annotations

import copy


class RuntimeApiError(Exception):
    """Base class for runtime errors."""


class InvalidNameError(RuntimeApiError, ValueError):
    """An invalid topic, service, action or node name."""


class TopicTypeError(RuntimeApiError, TypeError):
    """A topic used with two different message types, or a message of the wrong type."""


class ParameterError(RuntimeApiError, ValueError):
    """A parameter that is unknown, missing, of the wrong type or out of range.

    The one parameter error of the project: every parameter check raises it (or a
    subclass that adds context). ``problem`` says what is wrong and what is allowed;
    ``key`` is the parameter's full name, node first (``fcu_link.to_fcu.baud_rate``,
    ``talker.rate_hz``); ``source`` is where the value came from (a file, ``launch
    override``), when known. It reads ``source: key: problem``.
    """

    def __init__(self, problem: str, *, key: str = "", source: str | None = None) -> None:
        super().__init__(problem)
        self.problem = problem
        self.key = key
        self.source = source

    def prefixed(self, prefix: str) -> ParameterError:
        """The same error with ``prefix.`` in front of its key."""
        new = copy.copy(self)
        new.key = f"{prefix}.{self.key}" if prefix and self.key else prefix or self.key
        return new

    def with_source(self, source: str | None) -> ParameterError:
        """The same error, attributed to ``source`` (a file name)."""
        new = copy.copy(self)
        new.source = source
        return new

    def __str__(self) -> str:
        where = ": ".join(part for part in (self.source, self.key) if part)
        return f"{where}: {self.problem}" if where else self.problem


class ClockError(RuntimeApiError, ValueError):
    """Time asked to run backwards, or a period that is not positive."""


class FutureError(RuntimeApiError):
    """A future's result asked for before it is done, or set twice."""


class GoalCanceled(RuntimeApiError):
    """An action goal's cancel came while its execute callback waited on something else."""


class LaunchError(RuntimeApiError):
    """A launch description that names a missing factory or a bad node entry."""

