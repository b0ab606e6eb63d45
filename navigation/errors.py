"""Errors raised by the navigation package.

The path finder maps each :class:`PlanningError` to a ``PlanPath`` result code in one
place (:mod:`navigation.path_finder_node`); library code only raises them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt


class NavigationError(Exception):
    """Base class for navigation errors."""


class GraphError(NavigationError, ValueError):
    """The voxel graph cannot be built from these inputs."""


class EmptyCloud(GraphError):
    """The point cloud has no point inside the field."""


class ResolutionTooSmall(GraphError):
    """The grid would have too many cubes for the field at this resolution."""


class InvalidBounds(GraphError):
    """The field's minimum corner is not below its maximum corner on every axis."""


class MapFileError(NavigationError, OSError):
    """A map file that cannot be read or written (missing, empty, unknown format)."""


class PlanningError(NavigationError):
    """A path could not be planned. ``partial`` holds the best partial path (map-frame
    points, start first) when one was asked for and exists."""

    def __init__(self, message: str, partial: npt.NDArray[np.float64] | None = None) -> None:
        super().__init__(message)
        self.partial = partial


class OutOfBounds(PlanningError):
    """The start or the goal is outside the field's grid."""


class StartOccupied(PlanningError):
    """The start cube is non-viable or too close to an obstacle for the footprint."""


class GoalOccupied(PlanningError):
    """The goal cube is non-viable or too close to an obstacle for the footprint."""


class NoPathFound(PlanningError):
    """The search exhausted every cube reachable from the start."""


class PlanningTimedOut(PlanningError):
    """The search hit its time or expansion limit before reaching the goal."""


__all__ = ["EmptyCloud", "GoalOccupied", "GraphError", "InvalidBounds", "MapFileError",
           "NavigationError", "NoPathFound", "OutOfBounds", "PlanningError",
           "PlanningTimedOut", "ResolutionTooSmall", "StartOccupied"]
