"""Errors raised by the simulated flight controller: each one names what was wrong.

The scheduler's (``SchedulerError`` and its subclasses). The modules' parameters raise
the project's one :class:`runtime.errors.ParameterError`.
"""

from __future__ import annotations

from collections.abc import Sequence


class SchedulerError(Exception):
    """Base class for module declaration, resolution, rate and scheduling errors."""


class ModuleSpecError(SchedulerError, ValueError):
    """A module declaration is malformed; ``key`` is the path of the bad key."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"{key}: {message}")
        self.key = key
        self.message = message


class DependencyCycleError(SchedulerError):
    """The ``depends`` graph has a cycle; ``cycle`` lists it, first module repeated last."""

    def __init__(self, cycle: Sequence[str]) -> None:
        self.cycle = tuple(cycle)
        super().__init__("cyclic module dependency: " + " -> ".join(self.cycle))


class ConflictError(SchedulerError):
    """Module ``module`` declares a conflict with ``name``, which ``other`` brings in.

    ``name`` is the conflicting module itself or a ``@functionality`` that ``other``
    provides or requires.
    """

    def __init__(self, module: str, other: str, name: str) -> None:
        self.module = module
        self.other = other
        self.name = name
        if name == other:
            detail = f"module {module!r} conflicts with module {other!r}, which is selected"
        else:
            detail = f"module {module!r} conflicts with {name!r}, which module {other!r} brings in"
        super().__init__(detail)


class MissingFunctionalityError(SchedulerError):
    """``requirer`` needs ``missing`` (a module, ``@functionality`` or ``a|b``) that nothing gives.

    ``candidates`` are declared modules that would satisfy it but were not selected.
    """

    def __init__(self, requirer: str, missing: str, candidates: Sequence[str] = ()) -> None:
        self.requirer = requirer
        self.missing = missing
        self.candidates = tuple(candidates)
        hint = f" (declared but not selected: {', '.join(self.candidates)})" if candidates else ""
        super().__init__(
            f"module {requirer!r} requires {missing!r}, which no selected module provides{hint}"
        )


class RateError(SchedulerError, ValueError):
    """A rate the main loop cannot realise (prescaler not a positive integer)."""


class BindingError(SchedulerError):
    """Function names declared by modules and the callables bound to them do not match."""


class UnknownStrategyError(SchedulerError, KeyError):
    """An offset strategy name that is not in the registry."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else "unknown offset strategy"
