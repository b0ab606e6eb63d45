"""ground_station/foxglove_bridge_node.py: a Foxglove WebSocket client sees our topics as
ros2msg/cdr channels and receives their CDR bytes, decodable with the advertised type."""

from __future__ import annotations

import json
import struct
from typing import Any

from websockets.sync.client import connect

import interfaces
from ground_station.foxglove_bridge_node import FoxgloveBridgeNode
from quadmission.examples import Talker
from runtime import DeterministicExecutor

SUBPROTOCOL = "foxglove.sdk.v1"  # what foxglove-sdk speaks (Foxglove app and Studio do)
OP_MESSAGE_DATA = 1  # binary opcode of a message (Foxglove WebSocket protocol)


def _advertised(ws: Any, topic: str) -> dict[str, Any]:
    while True:
        frame = ws.recv(timeout=10)
        if isinstance(frame, str):
            msg = json.loads(frame)
            if msg.get("op") == "advertise":
                for channel in msg["channels"]:
                    if channel["topic"] == topic:
                        return dict(channel)


def test_foxglove_client_receives_cdr_on_a_ros2msg_channel() -> None:
    ex = DeterministicExecutor()
    talker = Talker(context=ex.context)
    bridge = FoxgloveBridgeNode(context=ex.context, parameter_overrides={"port": 0})
    for node in (talker, bridge):
        ex.add_node(node)
    try:
        assert bridge.host == "127.0.0.1"  # loopback unless told otherwise
        ex.spin_for(0.5)
        with connect(bridge.url, subprotocols=[SUBPROTOCOL]) as ws:  # type: ignore[list-item]
            channel = _advertised(ws, "/chatter")
            assert (channel["encoding"], channel["schemaEncoding"], channel["schemaName"]) == (
                "cdr", "ros2msg", "std_msgs/msg/String")
            assert channel["schema"].strip() == "string data"
            ws.send(json.dumps({"op": "subscribe",
                                "subscriptions": [{"id": 7, "channelId": channel["id"]}]}))
            texts: list[str] = []
            for _ in range(200):
                ex.spin_for(0.1)
                try:
                    frame = ws.recv(timeout=0.2)
                except TimeoutError:
                    continue
                if isinstance(frame, bytes) and frame[0] == OP_MESSAGE_DATA:
                    sub_id, _log_time = struct.unpack_from("<IQ", frame, 1)
                    assert sub_id == 7
                    msg = interfaces.deserialize(frame[13:], "std_msgs/msg/String")
                    texts.append(msg.data)
                    if len(texts) >= 3:
                        break
            assert len(texts) == 3  # the talker's "hello N", one after the other
            numbers = [int(t.removeprefix("hello ")) for t in texts]
            assert numbers == list(range(numbers[0], numbers[0] + 3))
    finally:
        bridge.close()
