"""Errors raised by the sim package (arena specs, the link's ordering).

A model parameter out of range (quadrotor, sensor, generator setting, FCU module) raises
the project's one :class:`runtime.errors.ParameterError`.
"""

from __future__ import annotations


class SimError(Exception):
    """Base class for simulator errors."""


class ArenaError(SimError, ValueError):
    """An arena spec or arena YAML that breaks a rule; names the offending key path.

    ``key`` is the path as written in the YAML (``pads[3].center``, ``robots[0].points[7]``),
    ``problem`` says what is wrong with it, ``source`` is the file it came from, if any.
    """

    def __init__(self, key: str, problem: str, source: str | None = None) -> None:
        self.key = key
        self.problem = problem
        self.source = source
        super().__init__(key, problem, source)

    def with_source(self, source: str) -> ArenaError:
        """The same error, attributed to the file ``source``."""
        return type(self)(self.key, self.problem, source)

    def __str__(self) -> str:
        where = ": ".join(part for part in (self.source, self.key) if part)
        return f"{where}: {self.problem}" if where else self.problem
