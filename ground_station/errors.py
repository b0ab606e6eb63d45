"""The ground station's own errors: bad input said in one line (the CLI maps them)."""

from __future__ import annotations


class GroundStationError(Exception):
    """Base class of the ground station's errors."""


class BagError(GroundStationError):
    """A bag folder or file that cannot be written, read or repaired as asked."""


class CommandError(GroundStationError):
    """An operator command that is malformed (an unknown command, a bad landing sequence)."""


__all__ = ["BagError", "CommandError", "GroundStationError"]
