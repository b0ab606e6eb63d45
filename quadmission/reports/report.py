"""Writing a scenario's ``report.json``: strict JSON, so any JSON reader can load it, and
stamped with the code that flew it (``code_version``), so a run can be flown again by the
same code."""

from __future__ import annotations

import functools
import json
import subprocess
from pathlib import Path
from typing import Any

from quadmission import __version__

REPORT_NAME = "report.json"
VERSION_KEY = "code_version"
_ROOT = Path(__file__).resolve().parents[2]  # the checkout that holds quadmission/
_GIT_TIMEOUT_S = 10.0


def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(_ROOT), *args], capture_output=True, text=True,
                          timeout=_GIT_TIMEOUT_S, check=True).stdout.strip()


@functools.cache
def code_version() -> str:
    """The code this process runs: the commit of the git checkout that holds quadmission
    (12 hex digits, with ``-dirty`` when a tracked file differs from it), or, outside a
    checkout (an installed package), ``quadmission <version>``."""
    if (_ROOT / ".git").exists():
        try:
            head = _git("rev-parse", "--short=12", "HEAD")
            dirty = _git("status", "--porcelain", "--untracked-files=no")
        except (OSError, subprocess.SubprocessError):
            pass
        else:
            return head + ("-dirty" if dirty else "")
    return f"quadmission {__version__}"


def report_json(report: dict[str, Any]) -> str:
    """``report`` as indented strict JSON; a NaN or an infinity is a bug (ValueError):
    unknown values are None (null)."""
    return json.dumps(report, indent=2, allow_nan=False) + "\n"


def write_report(out: Path, report: dict[str, Any]) -> Path:
    """Write ``report`` as ``out/report.json``; returns its path. ``report`` gains its
    ``code_version`` (:func:`code_version`) unless it has one, so the dict a scenario
    returns is the file it wrote."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / REPORT_NAME
    report.setdefault(VERSION_KEY, code_version())
    path.write_text(report_json(report), encoding="utf-8")
    return path


__all__ = ["REPORT_NAME", "VERSION_KEY", "code_version", "report_json", "write_report"]
