"""The node's logger, in rclpy's shape (``node.get_logger().info(...)``)."""

from __future__ import annotations

import logging
from typing import Any

from runtime.clock import Clock

__all__ = ["NodeLogger"]


class NodeLogger:
    """rclpy-style logger: ``node.get_logger().info(...)``, stamped with the node's time."""

    def __init__(self, name: str, clock: Clock) -> None:
        self._logger = logging.getLogger(f"quadmission.{name}")
        self._name = name
        self._clock = clock

    def _log(self, level: int, msg: str, *args: Any) -> None:
        if self._logger.isEnabledFor(level):
            t = self._clock.now().seconds
            self._logger.log(level, f"[{t:.3f}] [{self._name}] {msg}", *args)

    def debug(self, msg: str, *args: Any) -> None:
        self._log(logging.DEBUG, msg, *args)

    def info(self, msg: str, *args: Any) -> None:
        self._log(logging.INFO, msg, *args)

    def warning(self, msg: str, *args: Any) -> None:
        self._log(logging.WARNING, msg, *args)

    warn = warning

    def error(self, msg: str, *args: Any) -> None:
        self._log(logging.ERROR, msg, *args)

    def fatal(self, msg: str, *args: Any) -> None:
        self._log(logging.CRITICAL, msg, *args)

