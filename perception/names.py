"""The scanner's names that other packages use, without importing OpenCV."""

from __future__ import annotations

SCANNER_NODE_NAME = "aruco_scanner"
SCANNER_ENABLE_SERVICE = f"/{SCANNER_NODE_NAME}/enable"
"""std_srvs/SetBool: scanning on or off (off, the scanner also leaves the image topic)."""

__all__ = ["SCANNER_ENABLE_SERVICE", "SCANNER_NODE_NAME"]
