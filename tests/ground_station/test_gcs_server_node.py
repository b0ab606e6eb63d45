"""ground_station/gcs_server_node.py: the ground station as a launch-file node (the way a
launch over ROS 2 processes starts it): its page answers, it draws the field from the
layout file, and an authenticated command reaches /mission/command."""

from __future__ import annotations

import json
import urllib.request
from pathlib import Path
from typing import Any

import pytest

from ground_station.layout import BadLayout, Box, FieldLayout, PadInfo, load_layout
from ground_station.server import TOKEN_ENV
from runtime import (
    DeterministicExecutor,
    LaunchDescription,
    Node,
    NodeSpec,
    launch,
    qos_profile_default,
)

LAYOUT = FieldLayout(size=(20.0, 14.0, 4.0), name="test field",
                     obstacles=(Box("obstacle_0", (5.0, 5.0), (1.0, 2.0), 1.5),),
                     pads=(PadInfo(1, (1.5, 1.5), 1.0), PadInfo(2, (8.0, 3.0), 1.0)),
                     start_pad=1, points=((14, ((1, 10), (2, 30))),))


class _Commands(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("commands", **kwargs)
        self.heard: list[Any] = []
        self.create_subscription("quadmission_interfaces/msg/MissionCommand",
                                 "/mission/command", self.heard.append, qos_profile_default)


def test_layout_json_round_trips_and_bad_files_are_named(tmp_path: Path) -> None:
    path = tmp_path / "field.json"
    path.write_text(json.dumps(LAYOUT.to_json()))
    assert load_layout(path) == LAYOUT
    path.write_text('{"pads": []}')
    with pytest.raises(BadLayout, match=r"field\.json: not a field layout: KeyError"):
        load_layout(path)


def test_launched_ground_station_serves_and_sends_commands(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(TOKEN_ENV, "launch-token")
    field = tmp_path / "field.json"
    field.write_text(json.dumps(LAYOUT.to_json()))
    ex = DeterministicExecutor()
    listener = _Commands(context=ex.context)
    (station,) = launch(LaunchDescription((NodeSpec(
        "ground_station.gcs_server_node:GroundStationServerNode",
        parameters={"port": 0, "layout_file": str(field)}),)), ex)
    try:
        base = station.server.url  # type: ignore[attr-defined]
        assert base.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(base + "api/state", timeout=10) as reply:
            state = json.load(reply)
        assert state["layout"]["name"] == "test field"
        assert state["layout"]["points"] == {"14": {"1": 10, "2": 30}}
        request = urllib.request.Request(
            base + "api/command", method="POST",
            data=json.dumps({"command": "sequence", "sequence": [2, 1]}).encode(),
            headers={"Authorization": "Bearer launch-token",
                     "Content-Type": "application/json"})
        with urllib.request.urlopen(request, timeout=10) as reply:
            assert json.load(reply)["ok"]
        ex.spin_for(0.2)
        assert [list(m.sequence.pad_ids) for m in listener.heard] == [[2, 1]]
    finally:
        station.destroy_node()
