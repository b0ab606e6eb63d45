"""Nodes as processes: the clocked executor, one child process, the launcher (any transport)."""

from runtime.processes.child import TRANSPORTS, ProcessSpec
from runtime.processes.executor import ClockedExecutor, ProcessTransport
from runtime.processes.launcher import LaunchResult, process_specs, run_launch

__all__ = ["TRANSPORTS", "ClockedExecutor", "LaunchResult", "ProcessSpec", "ProcessTransport",
           "process_specs", "run_launch"]
