"""Writing a scenario's ``report.json``: strict JSON, so any JSON reader can load it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

REPORT_NAME = "report.json"


def report_json(report: dict[str, Any]) -> str:
    """``report`` as indented strict JSON; a NaN or an infinity is a bug (ValueError):
    unknown values are None (null)."""
    return json.dumps(report, indent=2, allow_nan=False) + "\n"


def write_report(out: Path, report: dict[str, Any]) -> Path:
    """Write ``report`` as ``out/report.json``; returns its path."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / REPORT_NAME
    path.write_text(report_json(report), encoding="utf-8")
    return path


__all__ = ["REPORT_NAME", "report_json", "write_report"]
