"""Nodes as processes on any process transport: child (one process), launcher, executor.

Import the modules themselves (``runtime.processes.launcher``...): ``python -m
runtime.processes.child`` runs a child, so this package imports none of them.
"""

__all__: list[str] = []
