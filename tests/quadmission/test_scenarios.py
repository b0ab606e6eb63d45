"""`quadmission sim --scenario arena-tour`: pictures and a report a person can check."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest

from quadmission.cli import main
from sim.markers import detect_markers


def test_arena_tour_writes_pictures_and_decodes_every_pad(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tour"
    assert main(["sim", "--scenario", "arena-tour", "--out", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["pads_total"] == 10 and report["all_decoded"]
    assert [p["id"] for p in report["pads"]] == list(range(1, 11))
    arena = cv2.imread(str(out / "arena.png"))
    assert arena is not None and arena.shape[1] == 1000
    for pad in report["pads"]:
        # the saved picture really shows that pad's marker, decoded again here
        frame = cv2.cvtColor(cv2.imread(str(out / pad["image"])), cv2.COLOR_BGR2RGB)
        assert frame.shape == (480, 640, 3)
        assert sorted(detect_markers(frame)) == [pad["id"]]
    assert "pad 10" in capsys.readouterr().err  # progress is shown


def test_a_random_arena_tour_also_decodes(tmp_path: Path) -> None:
    assert main(["sim", "--scenario", "arena-tour", "--random-arena", "--seed", "7",
                 "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["all_decoded"] and report["seed"] == 7


def test_a_bad_arena_file_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nfield: {size: [20, 14, 4]}\npads: []\nbogus: 1\n")
    assert main(["sim", "--arena", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml" in err and "bogus" in err
