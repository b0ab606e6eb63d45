"""ground_station/bag.py: rosbag2 MCAP that rosbags reads, sealed on time, repaired after
a real SIGKILL."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader

import interfaces
from ground_station.bag import (
    METADATA_NAME,
    BagWriter,
    bag_info,
    find_mcap,
    mcap_path,
    message_definition,
    repair_bag,
)
from ground_station.errors import BagError
from interfaces.qos import QoSProfile, ReliabilityPolicy

ROOT = Path(__file__).resolve().parents[2]


def _string(text: str) -> bytes:
    return interfaces.serialize(interfaces.new("std_msgs/msg/String", data=text))


def _read_all(folder: Path) -> list[tuple[str, int, object]]:
    with AnyReader([folder], default_typestore=interfaces.typestore()) as reader:
        return [(c.topic, t, reader.deserialize(raw, c.msgtype))
                for c, t, raw in reader.messages()]


def test_a_closed_bag_reads_back_with_rosbags(tmp_path: Path) -> None:
    folder = tmp_path / "bag"
    bag = BagWriter(folder)
    chatter = bag.add_topic("/chatter", "std_msgs/msg/String", QoSProfile())
    odom = bag.add_topic("/odom", "nav_msgs/msg/Odometry",
                         QoSProfile(reliability=ReliabilityPolicy.BEST_EFFORT))
    for i in range(30):
        bag.write(chatter, 1_000_000_000 + i * 100_000_000, _string(f"hello {i}"))
    bag.write(odom, 2_000_000_000, interfaces.serialize(interfaces.new(
        "nav_msgs/msg/Odometry", child_frame_id="base_link")))
    bag.close()

    assert mcap_path(folder).is_file()
    messages = _read_all(folder)
    assert [m.data for topic, _, m in messages if topic == "/chatter"] == [  # type: ignore[attr-defined]
        f"hello {i}" for i in range(30)]
    assert [m.child_frame_id for topic, _, m in messages if topic == "/odom"] == [  # type: ignore[attr-defined]
        "base_link"]
    with Reader(folder) as reader:  # the rosbag2 reader goes through metadata.yaml
        assert reader.message_count == 31
        assert reader.duration == 2_900_000_000 + 1  # rosbags counts the last ns
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
    assert qos["/odom"][0].reliability.name == "BEST_EFFORT"
    meta = yaml.safe_load((folder / METADATA_NAME).read_text())["rosbag2_bagfile_information"]
    assert meta["storage_identifier"] == "mcap"
    assert {t["topic_metadata"]["name"]: t["message_count"]
            for t in meta["topics_with_message_count"]} == {"/chatter": 30, "/odom": 1}
    info = bag_info(folder)
    assert info.indexed and info.message_count == 31
    assert info.duration_s == pytest.approx(2.9)


def test_schemas_are_ros2msg_text_as_rosbag2_writes_it() -> None:
    for name in ("nav_msgs/msg/Odometry", "sensor_msgs/msg/PointCloud2",
                 "px4_msgs/msg/VehicleOdometry"):
        expected, _ = interfaces.typestore().generate_msgdef(name, ros_version=2)
        assert message_definition(name) == expected
    # the action parts ROS 2 composes, which rosbags' generator cannot name
    text = message_definition("quadmission_interfaces/action/Navigate_FeedbackMessage")
    assert text.splitlines()[:2] == ["unique_identifier_msgs/UUID goal_id",
                                     "quadmission_interfaces/action/Navigate_Feedback feedback"]
    assert "MSG: nav_msgs/Path\n" in text


def test_chunks_are_sealed_on_disk_once_the_flush_period_passes(tmp_path: Path) -> None:
    host = [0.0]
    bag = BagWriter(tmp_path / "bag", flush_period_s=0.5, host_clock=lambda: host[0])
    topic = bag.add_topic("/chatter", "std_msgs/msg/String", QoSProfile())
    for i in range(10):
        host[0] = 0.1 * i  # 0.0 .. 0.9 s of host time
        bag.write(topic, i, _string(str(i)))
    # never closed: only what was sealed is on disk; the seal came at 0.5 s (message 5)
    on_disk = bag_info(tmp_path / "bag")
    assert not on_disk.indexed
    assert on_disk.message_count == 6
    assert bag.flushes == 1


def test_metadata_follows_new_topics_at_once_and_counts_within_its_period(
        tmp_path: Path) -> None:
    """A seal rewrites metadata.yaml when a topic came since the last rewrite (a reader of
    a crashed bag must know every topic), else only every METADATA_PERIOD_S."""
    from ground_station.bag import METADATA_PERIOD_S

    host = [0.0]
    folder = tmp_path / "bag"
    bag = BagWriter(folder, flush_period_s=0.5, host_clock=lambda: host[0])

    def on_disk() -> dict[str, int]:
        meta = yaml.safe_load((folder / METADATA_NAME).read_text())
        return {t["topic_metadata"]["name"]: t["message_count"]
                for t in meta["rosbag2_bagfile_information"]["topics_with_message_count"]}

    chatter = bag.add_topic("/chatter", "std_msgs/msg/String", QoSProfile())
    bag.write(chatter, 0, _string("0"))
    host[0] = 1.0
    bag.flush()
    assert on_disk() == {"/chatter": 1}  # the new topic
    bag.write(chatter, 1, _string("1"))
    host[0] = 2.0
    bag.flush()
    assert on_disk() == {"/chatter": 1}  # no new topic, within the period: not rewritten
    odom = bag.add_topic("/odom", "nav_msgs/msg/Odometry", QoSProfile())
    bag.write(odom, 2, interfaces.serialize(interfaces.new("nav_msgs/msg/Odometry")))
    host[0] = 3.0
    bag.flush()
    assert on_disk() == {"/chatter": 2, "/odom": 1}
    bag.write(chatter, 3, _string("3"))
    host[0] = 3.0 + METADATA_PERIOD_S
    bag.flush()
    assert on_disk() == {"/chatter": 3, "/odom": 1}  # the period passed
    bag.close()


def test_repair_after_a_real_sigkill_keeps_every_sealed_message(tmp_path: Path) -> None:
    folder = tmp_path / "bag"
    script = textwrap.dedent(f"""
        import os, signal
        from pathlib import Path
        import interfaces
        from interfaces.qos import QoSProfile
        from ground_station.bag import BagWriter
        bag = BagWriter(Path({str(folder)!r}), flush_period_s=0.05)
        c = bag.add_topic("/chatter", "std_msgs/msg/String", QoSProfile())
        for i in range(400):
            bag.write(c, i * 10_000_000, interfaces.serialize(
                interfaces.new("std_msgs/msg/String", data=str(i))))
            if i == 299:
                bag.flush()  # the last seal: 300 messages are safe
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, timeout=120, check=False,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert done.returncode == -9  # killed, not closed
    assert not bag_info(folder).indexed
    result = repair_bag(folder)
    assert result.repaired
    assert result.messages >= 300
    info = bag_info(folder)
    assert info.indexed and info.message_count == result.messages
    texts = [m.data for _, _, m in _read_all(folder)]  # type: ignore[attr-defined]
    assert texts == [str(i) for i in range(result.messages)]
    with Reader(folder) as reader:
        assert reader.message_count == result.messages
    again = repair_bag(folder)
    assert not again.repaired and again.messages == result.messages


def test_bad_paths_are_named(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="no bag at"):
        find_mcap(tmp_path / "missing")
    with pytest.raises(BagError, match=r"no \.mcap file"):
        find_mcap(tmp_path)
    BagWriter(tmp_path / "bag").close()
    with pytest.raises(BagError, match="already holds a bag"):
        BagWriter(tmp_path / "bag")
