"""rosbag2 MCAP bags: a crash-safe writer, ``info`` and ``repair``.

The layout is what ``ros2 bag record -s mcap`` writes (Jazzy, metadata version 9): a
folder ``NAME/`` with ``NAME_0.mcap`` (profile ``ros2``; one ``ros2msg`` schema per type,
the definition text from our typestore; ``cdr`` channels carrying their
``offered_qos_profiles``) and ``metadata.yaml``. rosbags' readers and Foxglove open it.

Crash safety: :class:`BagWriter` seals the open chunk, writes it with its message
indexes and flushes the file every ``flush_period_s`` (host time) while messages come,
and rewrites ``metadata.yaml`` at a seal when a topic was added since, and at least every
``METADATA_PERIOD_S`` (its counts and duration then lag by at most that; the topics and
the file it names, what a reader needs, never do). A process killed mid-run leaves a file
whose complete chunks are all readable; only the summary (the index at the end) is
missing, and the last, unsealed chunk is lost. :func:`repair_bag` reads every complete
record of such a file and rewrites it fully indexed, with a metadata.yaml that matches.

Pure module: the typestore (for schemas) and the mcap library, no runtime.
"""

from __future__ import annotations

import os
import time
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from rosbags.interfaces import Nodetype

from ground_station.errors import BagError
from interfaces import typestore
from interfaces.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

METADATA_NAME = "metadata.yaml"
ROSBAG2_VERSION = 9  # Jazzy's metadata version
PROFILE = "ros2"
SCHEMA_ENCODING = "ros2msg"
MESSAGE_ENCODING = "cdr"
DEFAULT_FLUSH_PERIOD_S = 0.5  # host seconds between sealed chunks (crash loses at most this)
#: host seconds between metadata.yaml rewrites at a seal without a new topic: a rewrite
#: costs ~10 ms (60 topics): twice a second, that is a fifth of a recorded mission's cost
METADATA_PERIOD_S = 10.0
CHUNK_SIZE = 4 * 1024 * 1024  # bytes: a chunk is sealed earlier when it grows past this


def _ref(typename: str) -> str:
    """A nested type as a .msg file names it: ``pkg/Name`` for messages; the action
    parts that ROS 2 composes (``pkg/action/Nav_Feedback``) keep their full name."""
    pkg, kind, name = typename.split("/")
    return f"{pkg}/{name}" if kind == "msg" else typename


def _field_text(node: Any, subdefs: dict[str, str]) -> str:
    kind, detail = node
    if kind == Nodetype.BASE:
        base, bound = detail
        return f"{base}<={bound}" if bound and base == "string" else str(base)
    if kind == Nodetype.NAME:
        if detail not in subdefs:
            subdefs[detail] = ""  # placeholder first: pre-order, as rosbag2 writes them
            subdefs[detail] = _definition_text(detail, subdefs)
        return _ref(detail)
    (sub_kind, sub), size = detail
    inner = _field_text((sub_kind, sub), subdefs)
    count = "" if not size else (str(size) if kind == Nodetype.ARRAY else f"<={size}")
    return f"{inner}[{count}]"


def _definition_text(typename: str, subdefs: dict[str, str]) -> str:
    constants, fields = typestore().fielddefs[typename]
    lines = [f"{ctype} {name}={value}" for name, ctype, value in constants]
    lines += [f"{_field_text(node, subdefs)} {name}" for name, node in fields
              if name != "structure_needs_at_least_one_member"]
    return "\n".join([*lines, ""])


def message_definition(typename: str) -> str:
    """The ``ros2msg`` schema text of ``typename`` as rosbag2 stores it: its fields, then
    each nested type after a line of 80 ``=`` and ``MSG: pkg/Name``."""
    subdefs: dict[str, str] = {}
    text = _definition_text(typename, subdefs)
    return text + "".join(f"{'=' * 80}\nMSG: {_ref(name)}\n{body}"
                          for name, body in subdefs.items())


def mcap_path(folder: Path) -> Path:
    """Where ``ros2 bag`` puts the first (and our only) storage file of bag ``folder``."""
    return folder / f"{folder.name}_0.mcap"


def find_mcap(path: Path) -> Path:
    """The .mcap file of a bag folder (or the file itself); BagError when there is none."""
    if path.is_file():
        if path.suffix != ".mcap":
            raise BagError(f"{path} is not an .mcap file")
        return path
    if not path.is_dir():
        raise BagError(f"no bag at {path}: neither a folder nor an .mcap file")
    files = sorted(path.glob("*.mcap"))
    if not files:
        raise BagError(f"no .mcap file in {path}")
    if len(files) > 1:
        raise BagError(f"{path} holds {len(files)} .mcap files; name one of them")
    return files[0]


def qos_yaml(qos: QoSProfile) -> list[dict[str, Any]]:
    """A QoS profile as rosbag2 (metadata version 9) stores ``offered_qos_profiles``."""
    infinite = {"sec": 2147483647, "nsec": 4294967295}  # rmw's "infinite" duration
    return [{
        "history": "keep_last" if qos.history is HistoryPolicy.KEEP_LAST else "keep_all",
        "depth": qos.depth,
        "reliability": ("reliable" if qos.reliability is ReliabilityPolicy.RELIABLE
                        else "best_effort"),
        "durability": ("transient_local" if qos.durability is DurabilityPolicy.TRANSIENT_LOCAL
                       else "volatile"),
        "deadline": dict(infinite),
        "lifespan": dict(infinite),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(infinite),
        "avoid_ros_namespace_conventions": False,
    }]


@dataclass
class _Topic:
    name: str
    msgtype: str
    qos: list[dict[str, Any]]
    channel_id: int
    count: int = 0


def _metadata(file: Path, topics: list[_Topic], start_ns: int | None,
              end_ns: int | None) -> dict[str, Any]:
    count = sum(t.count for t in topics)
    start = start_ns or 0
    duration = max(0, (end_ns or 0) - start) if start_ns is not None else 0
    store = typestore()
    return {"rosbag2_bagfile_information": {
        "version": ROSBAG2_VERSION,
        "storage_identifier": "mcap",
        "relative_file_paths": [file.name],
        "duration": {"nanoseconds": duration},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": count,
        "topics_with_message_count": [
            {"topic_metadata": {"name": t.name, "type": t.msgtype,
                                "serialization_format": MESSAGE_ENCODING,
                                "offered_qos_profiles": t.qos,
                                "type_description_hash": store.hash_rihs01(t.msgtype)},
             "message_count": t.count}
            for t in topics],
        "compression_format": "",
        "compression_mode": "",
        "files": [{"path": file.name,
                   "starting_time": {"nanoseconds_since_epoch": start},
                   "duration": {"nanoseconds": duration},
                   "message_count": count}],
        "custom_data": None,
        "ros_distro": "jazzy",
    }}


#: libyaml's safe dumper where PyYAML has it: the same text, 6x faster (PyYAML's Python
#: dumper, writing metadata.yaml at every seal twice a second, costs 7 % of a recorded
#: mission's main thread)
_YAML_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


def _write_metadata(folder: Path, metadata: dict[str, Any]) -> None:
    tmp = folder / (METADATA_NAME + ".tmp")
    tmp.write_text(yaml.dump(metadata, Dumper=_YAML_DUMPER, sort_keys=False))
    os.replace(tmp, folder / METADATA_NAME)


class BagWriter:
    """Writes one rosbag2 MCAP bag into ``folder`` (created; must not hold a bag yet).

    >>> bag = BagWriter(Path("runs/x/bag"))
    >>> cid = bag.add_topic("/chatter", "std_msgs/msg/String", QoSProfile())
    >>> bag.write(cid, t_ns, cdr_bytes)  # sealed and flushed every flush_period_s
    >>> bag.close()                       # summary, index and final metadata.yaml
    """

    def __init__(self, folder: Path, *, flush_period_s: float = DEFAULT_FLUSH_PERIOD_S,
                 host_clock: Callable[[], float] = time.monotonic) -> None:
        if flush_period_s <= 0:
            raise BagError(f"flush_period_s must be > 0 s, got {flush_period_s}")
        self.folder = folder
        self.path = mcap_path(folder)
        if self.path.exists() or (folder / METADATA_NAME).exists():
            raise BagError(f"{folder} already holds a bag; choose another folder")
        folder.mkdir(parents=True, exist_ok=True)
        self._file: BinaryIO = self.path.open("xb")
        self._writer = Writer(self._file, chunk_size=CHUNK_SIZE,
                              compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="quadmission")
        self._schemas: dict[str, int] = {}
        self._topics: dict[int, _Topic] = {}
        self._clock = host_clock
        self._period = flush_period_s
        self._last_flush = host_clock()
        self._last_metadata = self._last_flush
        self._topics_in_metadata = 0
        self._start_ns: int | None = None
        self._end_ns: int | None = None
        self.flushes = 0
        self.closed = False
        _write_metadata(folder, _metadata(self.path, [], None, None))

    def add_topic(self, topic: str, msgtype: str, qos: QoSProfile) -> int:
        """Register a topic; returns its channel id for :meth:`write`."""
        return self._add(topic, msgtype, qos_yaml(qos))

    def _add(self, topic: str, msgtype: str, qos: list[dict[str, Any]]) -> int:
        schema_id = self._schemas.get(msgtype)
        if schema_id is None:
            msgdef = message_definition(msgtype)
            schema_id = self._writer.register_schema(msgtype, SCHEMA_ENCODING,
                                                     msgdef.encode())
            self._schemas[msgtype] = schema_id
        channel_id = self._writer.register_channel(
            topic, MESSAGE_ENCODING, schema_id,
            {"offered_qos_profiles": yaml.safe_dump(qos, sort_keys=False).strip()})
        self._topics[channel_id] = _Topic(topic, msgtype, qos, channel_id)
        return channel_id

    def write(self, channel_id: int, t_ns: int, data: bytes) -> None:
        """Add one CDR message received at ``t_ns``; seal and flush when the period is up."""
        topic = self._topics[channel_id]
        self._writer.add_message(channel_id, log_time=t_ns, data=data, publish_time=t_ns,
                                 sequence=topic.count)
        topic.count += 1
        if self._start_ns is None or t_ns < self._start_ns:
            self._start_ns = t_ns
        if self._end_ns is None or t_ns > self._end_ns:
            self._end_ns = t_ns
        if self._clock() - self._last_flush >= self._period:
            self.flush()

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self._topics.values())

    def flush(self) -> None:
        """Seal the open chunk, write it with its indexes, flush the file; rewrite the
        metadata when a topic was added or ``METADATA_PERIOD_S`` passed."""
        self._writer.flush()
        self._file.flush()
        now = self._last_flush = self._clock()
        self.flushes += 1
        if (len(self._topics) != self._topics_in_metadata
                or now - self._last_metadata >= METADATA_PERIOD_S):
            self._last_metadata = now
            self._topics_in_metadata = len(self._topics)
            _write_metadata(self.folder, _metadata(self.path, list(self._topics.values()),
                                                   self._start_ns, self._end_ns))

    def close(self) -> None:
        """Write the summary (statistics, chunk and message indexes) and metadata.yaml."""
        if self.closed:
            return
        self.closed = True
        self._writer.finish()
        self._file.close()
        _write_metadata(self.folder, _metadata(self.path, list(self._topics.values()),
                                               self._start_ns, self._end_ns))


@dataclass(frozen=True)
class TopicInfo:
    name: str
    msgtype: str
    count: int


@dataclass(frozen=True)
class BagInfo:
    """What ``quadmission bag info`` prints."""

    path: Path
    indexed: bool  # the file has its summary (closed cleanly, or repaired)
    topics: tuple[TopicInfo, ...]
    start_ns: int | None
    end_ns: int | None

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics)

    @property
    def duration_s(self) -> float:
        if self.start_ns is None or self.end_ns is None:
            return 0.0
        return (self.end_ns - self.start_ns) / 1e9

    def to_json(self) -> dict[str, Any]:
        return {"path": str(self.path), "indexed": self.indexed,
                "messages": self.message_count, "duration_s": round(self.duration_s, 3),
                "start_ns": self.start_ns, "end_ns": self.end_ns,
                "topics": [{"name": t.name, "type": t.msgtype, "count": t.count}
                           for t in self.topics]}


@dataclass
class _Scan:
    schemas: dict[int, Schema]
    channels: dict[int, Channel]
    messages: int
    complete: bool  # the stream ended cleanly (footer and magic), not mid-record
    error: str | None


def _records(stream: BinaryIO, scan: _Scan) -> Iterator[Any]:
    """Every complete record of a possibly truncated file; ``scan.error`` says where it
    stopped when the tail was cut."""
    reader = StreamReader(stream, skip_magic=False, emit_chunks=False)
    try:
        yield from reader.records
        scan.complete = True
    except Exception as exc:  # a record cut by the kill: EndOfFile, or zstd/struct errors
        scan.error = f"{type(exc).__name__}: {exc}"


def _summary(path: Path) -> Any:
    try:
        with path.open("rb") as f:
            return make_reader(f).get_summary()
    except (McapError, EOFError, ValueError, OSError, KeyError):
        return None


def bag_info(path: Path) -> BagInfo:
    """Topics, counts and time span of a bag (a folder or an .mcap). A file without its
    summary (a killed run) is scanned record by record."""
    file = find_mcap(path)
    summary = _summary(file)
    if summary is not None and summary.statistics is not None:
        stats = summary.statistics
        topics = tuple(TopicInfo(ch.topic, summary.schemas[ch.schema_id].name
                                 if ch.schema_id in summary.schemas else "",
                                 stats.channel_message_counts.get(cid, 0))
                       for cid, ch in sorted(summary.channels.items()))
        has = stats.message_count > 0
        return BagInfo(file, True, topics, stats.message_start_time if has else None,
                       stats.message_end_time if has else None)
    scan = _Scan({}, {}, 0, False, None)
    counts: Counter[int] = Counter()
    start = end = None
    with file.open("rb") as f:
        for record in _records(f, scan):
            if isinstance(record, Schema):
                scan.schemas[record.id] = record
            elif isinstance(record, Channel):
                scan.channels[record.id] = record
            elif isinstance(record, Message):
                counts[record.channel_id] += 1
                start = record.log_time if start is None else min(start, record.log_time)
                end = record.log_time if end is None else max(end, record.log_time)
    topics = tuple(TopicInfo(ch.topic, scan.schemas[ch.schema_id].name
                             if ch.schema_id in scan.schemas else "", counts[cid])
                   for cid, ch in sorted(scan.channels.items()))
    return BagInfo(file, False, topics, start, end)


@dataclass(frozen=True)
class RepairResult:
    """What :func:`repair_bag` did."""

    path: Path
    repaired: bool  # False: the file was already indexed, nothing to do
    messages: int
    topics: int
    bytes_dropped: int  # the cut tail (an unsealed chunk) that could not be read
    stopped_at: str | None  # why the scan stopped before the end of the file

    def to_json(self) -> dict[str, Any]:
        return {"path": str(self.path), "repaired": self.repaired, "messages": self.messages,
                "topics": self.topics, "bytes_dropped": self.bytes_dropped,
                "stopped_at": self.stopped_at}


def repair_bag(path: Path) -> RepairResult:
    """Rewrite a bag whose writer was killed into a fully indexed one, in place, and
    rewrite its metadata.yaml. Complete records are kept; the cut tail is dropped. A
    file that already has its summary is left as it is."""
    file = find_mcap(path)
    folder = file.parent
    summary = _summary(file)
    if summary is not None and summary.statistics is not None:
        info = bag_info(file)
        return RepairResult(file, False, info.message_count, len(info.topics), 0, None)
    scan = _Scan({}, {}, 0, False, None)
    tmp = file.with_name(file.name + ".repair")
    topics: dict[int, _Topic] = {}
    start = end = None
    good_end = 0
    size = file.stat().st_size
    with file.open("rb") as src, tmp.open("wb") as dst:
        writer = Writer(dst, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        writer.start(profile=PROFILE, library="quadmission (repaired)")
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        for record in _records(src, scan):
            if isinstance(record, Schema) and record.id not in schema_ids:
                schema_ids[record.id] = writer.register_schema(record.name, record.encoding,
                                                               record.data)
                scan.schemas[record.id] = record
            elif isinstance(record, Channel) and record.id not in channel_ids:
                channel_ids[record.id] = writer.register_channel(
                    record.topic, record.message_encoding,
                    schema_ids.get(record.schema_id, 0), dict(record.metadata))
                schema = scan.schemas.get(record.schema_id)
                qos = yaml.safe_load(record.metadata.get("offered_qos_profiles", "[]")) or []
                topics[record.id] = _Topic(record.topic, schema.name if schema else "", qos,
                                           channel_ids[record.id])
            elif isinstance(record, Message) and record.channel_id in channel_ids:
                writer.add_message(channel_ids[record.channel_id], log_time=record.log_time,
                                   data=record.data, publish_time=record.publish_time,
                                   sequence=record.sequence)
                topics[record.channel_id].count += 1
                scan.messages += 1
                start = record.log_time if start is None else min(start, record.log_time)
                end = record.log_time if end is None else max(end, record.log_time)
                good_end = src.tell()
        writer.finish()
    if scan.complete and scan.error is None and scan.messages == 0 and not topics:
        tmp.unlink()
        raise BagError(f"{file} holds no MCAP records")
    os.replace(tmp, file)
    _write_metadata(folder, _metadata(file, list(topics.values()), start, end))
    dropped = 0 if scan.complete else max(0, size - good_end)
    return RepairResult(file, True, scan.messages, len(topics), dropped, scan.error)


__all__ = ["DEFAULT_FLUSH_PERIOD_S", "METADATA_NAME", "BagInfo", "BagWriter", "RepairResult",
           "TopicInfo", "bag_info", "find_mcap", "mcap_path", "message_definition", "qos_yaml",
           "repair_bag"]
