"""report.json (quadmission/reports/report.py): strict JSON, stamped with the code that
flew the run."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pytest

from quadmission import __version__
from quadmission.reports import report as report_module
from quadmission.reports.report import VERSION_KEY, code_version, write_report

ROOT = Path(report_module.__file__).resolve().parents[2]


def test_a_report_is_stamped_with_the_commit_of_the_checkout_that_flew_it(
        tmp_path: Path) -> None:
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True,
                          text=True, check=True).stdout.strip()
    report = {"result": "completed"}
    written = json.loads(write_report(tmp_path, report).read_text())
    assert written == report  # the caller's report is the file
    assert written["result"] == "completed"
    version = written[VERSION_KEY]
    assert head.startswith(version.removesuffix("-dirty")) and len(head) > 12
    assert len(version.removesuffix("-dirty")) == 12


def test_a_version_the_report_carries_is_kept(tmp_path: Path) -> None:
    written = json.loads(write_report(tmp_path, {VERSION_KEY: "abc"}).read_text())
    assert written[VERSION_KEY] == "abc"


def test_outside_a_checkout_the_version_is_the_package_s(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(report_module, "_ROOT", tmp_path)
    code_version.cache_clear()
    try:
        assert code_version() == f"quadmission {__version__}"
    finally:
        code_version.cache_clear()


def test_a_not_a_number_in_a_report_is_an_error_not_invalid_json(tmp_path: Path) -> None:
    with pytest.raises(ValueError):
        write_report(tmp_path, {"touchdown_rmse_m": math.nan})
