"""Recording messages to MCAP (ROS 2 CDR, opens in Foxglove and Lichtblick) or ROS 1 .bag
(layer 4).

`Recorder` writes robotrial.msgs messages; `BusRecorder` subscribes to topics of a bus
and records what they carry (like `ros2 bag record`). Messages are serialized by
`robotrial.msgs.cdr` (ROS 2 CDR, ROS 1) and read back through the `rosbags` type stores
(ROS 2 Humble, ROS 1 Noetic); the MCAP schemas are the full
`.msg` definitions of robotrial.msgs, in the `ros2msg` encoding that ROS 2 tools write,
and its chunks are compressed (LZ4 by default: quick to write; zstd: smaller; both as
rosbag2 and the MCAP tools write them, and Foxglove and Lichtblick read them).

What other readers need, and gets written for them:

- log times are at least 1 ns: ROS 1's `rosbag_storage` drops index entries stamped 0,
  and a simulation starts at 0;
- a .bag's LZ4 chunks are frames without a content size, with a content checksum and
  independent blocks, the only kind `roslz4` (Python `rosbag`) decompresses;
- a latched topic is a latching connection in a .bag and, in an MCAP, a channel whose
  `offered_qos_profiles` say transient local (as rosbag2 writes them), so converters
  and players keep it latched.

`recover_mcap` and `recover_bag` rescue a recording cut short (the process killed, the
disk full): every message of the complete chunks goes into a new, indexed file that
seeking readers open. A `BusRecorder` whose file cannot be written stops recording and
keeps the error in `error`, so the run can stop and say so.
"""

from __future__ import annotations

import struct
import threading
from pathlib import Path
from typing import Any

import lz4.frame
import numpy as np
import yaml
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from rosbags.rosbag1 import Writer as Bag1Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from robotrial.msgs import Message, cdr, lookup_message
from robotrial.msgs.core import definition, dependencies, full_definition
from robotrial.msgs.names import LATCHED_TOPICS
from robotrial.ros.bus import Bus, Node

FORMATS = ("mcap", "bag")
COMPRESSIONS = {
    "lz4": CompressionType.LZ4,
    "zstd": CompressionType.ZSTD,
    "none": CompressionType.NONE,
}
_STORES: dict[str, Any] = {}
_STORE_LOCK = threading.Lock()
_READY: set[tuple[int, str]] = set()
MIN_LOG_TIME_NS = 1  # rosbag_storage's TIME_MIN: an index entry at 0 is dropped
BAG_CHUNK_BYTES = 768 * 1024  # `rosbag record`'s default chunk size
_INFINITE = {"sec": 9223372036, "nsec": 854775807}


def offered_qos(latched: bool) -> str:
    """A channel's `offered_qos_profiles` as rosbag2 (Jazzy) writes them in MCAP
    metadata: reliable, keep last, transient local for a latched topic."""
    profile = {
        "history": "keep_last",
        "depth": 1 if latched else 10,
        "reliability": "reliable",
        "durability": "transient_local" if latched else "volatile",
        "deadline": dict(_INFINITE),
        "lifespan": dict(_INFINITE),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(_INFINITE),
        "avoid_ros_namespace_conventions": False,
    }
    return yaml.safe_dump([profile], sort_keys=False)


def _roslz4_frame(data: bytes) -> bytes:
    """An LZ4 frame that ROS 1's roslz4 reads: no content size, a content checksum,
    independent blocks."""
    return lz4.frame.compress(data, store_size=False, content_checksum=True, block_linked=False)


def format_of(path: str | Path) -> str:
    """ "mcap" or "bag" from the file name; a clear error for anything else."""
    suffix = Path(path).suffix.lower()
    if suffix == ".mcap":
        return "mcap"
    if suffix == ".bag":
        return "bag"
    raise ValueError(f"{path}: a recording is a .mcap (ROS 2) or .bag (ROS 1) file")


def typestore(dialect: str):
    """The rosbags type store of a dialect ("ros2": Humble, "ros1": Noetic)."""
    with _STORE_LOCK:
        if dialect not in _STORES:
            _STORES[dialect] = get_typestore(
                Stores.ROS2_HUMBLE if dialect == "ros2" else Stores.ROS1_NOETIC
            )
        return _STORES[dialect]


def _store_name(cls: type[Message]) -> str:
    """The name rosbags keeps a type under: a service's request and response
    (`pkg/srv/Name_Request`) go under `pkg/msg/...`, the only middle part it keeps."""
    return cls.__ros_type__.replace("/srv/", "/msg/", 1)


def ensure_type(store, cls: type[Message], dialect: str) -> None:
    """Register `cls` (and what it contains) in the store if the store lacks it."""
    key = (id(store), cls.__ros_type__)
    if key in _READY:
        return
    missing = [c for c in dependencies(cls) if _store_name(c) not in store.types]
    if not missing:
        _READY.add(key)
        return
    types: dict = {}
    for c in missing:
        types.update(get_types_from_msg(definition(c, dialect), _store_name(c)))
    with _STORE_LOCK:
        store.register(types)
    _READY.add(key)


def serialize(msg: Message, dialect: str = "ros2") -> bytes:
    """CDR (ros2) or ROS 1 bytes of a message (the bytes rosbridge's cbor-raw sends)."""
    return cdr.serialize(msg) if dialect == "ros2" else cdr.serialize_ros1(msg)


def _field_back(value: Any, spec) -> Any:
    if spec.msg is not None:
        if spec.array is not None:
            return [from_rosbags(v, spec.msg) for v in value]
        return from_rosbags(value, spec.msg)
    if spec.is_bytes:
        return np.asarray(value, dtype=np.uint8).tobytes()
    if spec.array is not None:
        if isinstance(value, np.ndarray):
            return value.tolist()
        return list(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


def from_rosbags(obj: Any, cls: type[Message]) -> Message:
    """Our message from a rosbags object of the same type (either dialect)."""
    kwargs = {}
    rename = cls.__ros1__.rename
    for spec in cls.__fields_spec__:
        name = spec.name if hasattr(obj, spec.name) else rename.get(spec.name, spec.name)
        if hasattr(obj, name):
            kwargs[spec.name] = _field_back(getattr(obj, name), spec)
    return cls(**kwargs)


def deserialize(data: bytes, type_name: str, dialect: str = "ros2") -> Message:
    cls = lookup_message(type_name)
    if cls is None:
        raise ValueError(f"recording: message type {type_name!r} is not in robotrial.msgs")
    store = typestore(dialect)
    ensure_type(store, cls, dialect)
    if dialect == "ros2":
        obj = store.deserialize_cdr(data, _store_name(cls))
    else:
        obj = store.deserialize_ros1(data, _store_name(cls))
    return from_rosbags(obj, cls)


def message_stamp(msg: Message) -> float | None:
    """The header stamp of a message (of the first transform for TF), if it has one."""
    header = getattr(msg, "header", None)
    if header is None:
        transforms = getattr(msg, "transforms", None)
        if transforms:
            header = transforms[0].header
    if header is None:
        return None
    return header.stamp.sec + header.stamp.nanosec * 1e-9


class Recorder:
    """Writes messages to `path` (.mcap or .bag). Use as a context manager or `close()`.
    `compression`: lz4, zstd or none (a .bag takes lz4 or none).

    `write(topic, msg, stamp, latched)`: `stamp` (s) is the log time; without it the
    message's header stamp, else the last time written (never below 1 ns). A topic keeps
    the type of its first message; `latched` (default: the topic is one of
    `LATCHED_TOPICS`) is decided by its first message too.
    """

    def __init__(self, path: str | Path, compression: str = "lz4") -> None:
        self.path = Path(path)
        self.format = format_of(self.path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.counts: dict[str, int] = {}
        self._types: dict[str, str] = {}
        self._channels: dict[str, Any] = {}
        self._last = 0.0
        self._lock = threading.Lock()
        self._closed = False
        if compression not in COMPRESSIONS or (self.format == "bag" and compression == "zstd"):
            choices = "lz4 or none" if self.format == "bag" else ", ".join(COMPRESSIONS)
            raise ValueError(f"{self.path}: compression {compression!r}; choose {choices}")
        if self.format == "mcap":
            self._file = open(self.path, "wb")
            self._mcap = McapWriter(self._file, compression=COMPRESSIONS[compression])
            self._mcap.start(profile="ros2", library="robotrial")
            self._schemas: dict[str, int] = {}
        else:
            if self.path.exists():
                self.path.unlink()
            self._bag = Bag1Writer(self.path)
            self._bag.chunk_threshold = BAG_CHUNK_BYTES
            if compression == "lz4":
                self._bag.set_compression(Bag1Writer.CompressionFormat.LZ4)
                self._bag.compressor = _roslz4_frame
            self._bag.open()

    def _channel(self, topic: str, cls: type[Message], latched: bool | None) -> Any:
        name = cls.__ros_type__
        known = self._types.get(topic)
        if known is not None:
            if known != name:
                raise ValueError(f"recording: topic {topic} carries {known}, not {name}")
            return self._channels[topic]
        if latched is None:
            latched = topic in LATCHED_TOPICS
        if self.format == "mcap":
            if name not in self._schemas:
                self._schemas[name] = self._mcap.register_schema(
                    name=name, encoding="ros2msg", data=full_definition(cls).encode()
                )
            ch = self._mcap.register_channel(
                topic=topic,
                message_encoding="cdr",
                schema_id=self._schemas[name],
                metadata={"offered_qos_profiles": offered_qos(latched)},
            )
        else:
            store = typestore("ros1")
            ensure_type(store, cls, "ros1")
            ch = self._bag.add_connection(topic, name, typestore=store, latching=int(latched))
        self._types[topic] = name
        self._channels[topic] = ch
        return ch

    def write(
        self, topic: str, msg: Message, stamp: float | None = None, latched: bool | None = None
    ) -> None:
        if not isinstance(msg, Message):
            raise TypeError(
                f"recording {topic}: expected a robotrial.msgs message, got {type(msg)}"
            )
        t = stamp if stamp is not None else message_stamp(msg)
        with self._lock:
            if self._closed:
                raise ValueError(f"recording {self.path} is closed")
            t = self._last if t is None else t
            self._last = max(self._last, t)
            ns = max(round(t * 1e9), MIN_LOG_TIME_NS)
            ch = self._channel(topic, type(msg), latched)
            if self.format == "mcap":
                self._mcap.add_message(
                    channel_id=ch, log_time=ns, publish_time=ns, data=serialize(msg, "ros2")
                )
            else:
                self._bag.write(ch, ns, serialize(msg, "ros1"))
            self.counts[topic] = self.counts.get(topic, 0) + 1

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            # the file is let go even when finishing it fails (a full disk)
            if self.format == "mcap":
                try:
                    self._mcap.finish()
                finally:
                    self._file.close()
            else:
                try:
                    self._bag.close()
                finally:
                    if self._bag.bio is not None and not self._bag.bio.closed:
                        self._bag.bio.close()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class BusRecorder(Node):
    """Records topics of a bus into a Recorder (every message, in arrival order).

    When the file cannot be written (a full disk, a quota), recording stops and `error`
    holds the OSError; the caller decides whether the run goes on."""

    def __init__(
        self, bus: Bus, recorder: Recorder, topics: list[str], name: str = "/recorder"
    ) -> None:
        super().__init__(bus, bus.unique_node_name(name))
        self.recorder = recorder
        self.error: OSError | None = None
        for topic in topics:
            self.create_subscription(topic, None, lambda msg, t=topic: self._on(t, msg))

    def _on(self, topic: str, msg: Any) -> None:
        if not isinstance(msg, Message) or self.error is not None:
            return
        try:
            self.recorder.write(topic, msg, latched=self.bus.is_latched(topic))
        except OSError as exc:
            self.error = exc


def recover_mcap(path: str | Path, out: str | Path) -> dict[str, int]:
    """Copy every readable message of an MCAP file cut short (no summary, a torn last
    chunk) into a complete, indexed file `out`; the messages per topic recovered."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, DataEnd, Footer, Message, Schema
    from mcap.stream_reader import StreamReader

    src, dst = Path(path), Path(out)
    if src.resolve() == dst.resolve():
        raise ValueError(f"{src}: write the recovered recording to another file")
    counts: dict[str, int] = {}
    schemas: dict[int, int] = {}
    channels: dict[int, tuple[int, str]] = {}
    with open(src, "rb") as f, open(dst, "wb") as g:
        writer = McapWriter(g, compression=CompressionType.LZ4)
        writer.start(profile="ros2", library="robotrial recover")
        try:
            for record in StreamReader(f, skip_magic=False, emit_chunks=False).records:
                if isinstance(record, Schema):
                    schemas[record.id] = writer.register_schema(
                        record.name, record.encoding, record.data
                    )
                elif isinstance(record, Channel):
                    channels[record.id] = (
                        writer.register_channel(
                            record.topic,
                            record.message_encoding,
                            schemas.get(record.schema_id, 0),
                            record.metadata,
                        ),
                        record.topic,
                    )
                elif isinstance(record, Message) and record.channel_id in channels:
                    cid, topic = channels[record.channel_id]
                    writer.add_message(
                        cid, record.log_time, record.data, record.publish_time, record.sequence
                    )
                    counts[topic] = counts.get(topic, 0) + 1
                elif isinstance(record, DataEnd | Footer):
                    break
        except (McapError, EOFError, ValueError, struct.error):
            pass  # the torn end of the file: what came before it is kept
        writer.finish()
    return counts


_BAG_MAGIC = b"#ROSBAG V2.0\n"
_OP_MSG_DATA, _OP_CHUNK, _OP_CONNECTION = 0x02, 0x05, 0x07


def _bag_fields(data: bytes) -> dict[str, bytes]:
    """The `name=value` fields of a ROS 1 bag record header."""
    fields, pos = {}, 0
    while pos + 4 <= len(data):
        (n,) = struct.unpack_from("<I", data, pos)
        name, _, value = data[pos + 4 : pos + 4 + n].partition(b"=")
        fields[name.decode()] = value
        pos += 4 + n
    return fields


def _bag_records(data: bytes, pos: int = 0):
    """(header fields, data) of each complete record of a ROS 1 bag from `pos` on."""
    while pos + 4 <= len(data):
        (hlen,) = struct.unpack_from("<I", data, pos)
        if pos + 8 + hlen > len(data):
            return
        header = _bag_fields(data[pos + 4 : pos + 4 + hlen])
        (dlen,) = struct.unpack_from("<I", data, pos + 4 + hlen)
        start = pos + 8 + hlen
        if start + dlen > len(data) or "op" not in header:
            return
        yield header, data[start : start + dlen]
        pos = start + dlen


def _unchunk(header: dict[str, bytes], data: bytes) -> bytes:
    compression = header.get("compression", b"none").decode()
    if compression == "lz4":
        return lz4.frame.decompress(data)
    if compression == "bz2":
        import bz2

        return bz2.decompress(data)
    return data


def recover_bag(path: str | Path, out: str | Path) -> dict[str, int]:
    """Copy every message of the complete chunks of a ROS 1 bag without an index (its
    writer killed, or the disk full) into an indexed bag `out`; messages per topic."""
    src, dst = Path(path), Path(out)
    if src.resolve() == dst.resolve():
        raise ValueError(f"{src}: write the recovered recording to another file")
    data = src.read_bytes()
    if not data.startswith(_BAG_MAGIC):
        raise ValueError(f"{src} is not a ROS 1 bag (no '#ROSBAG V2.0' at its start)")
    if dst.exists():
        dst.unlink()
    counts: dict[str, int] = {}
    conns: dict[int, Any] = {}
    topics: dict[int, str] = {}
    writer = Bag1Writer(dst)
    writer.set_compression(Bag1Writer.CompressionFormat.LZ4)
    writer.compressor = _roslz4_frame
    writer.open()
    try:
        for header, body in _bag_records(data, len(_BAG_MAGIC)):
            if header["op"] != bytes([_OP_CHUNK]):
                continue
            try:
                inner = _unchunk(header, body)
            except (RuntimeError, OSError, ValueError):
                break  # the torn last chunk
            for h, d in _bag_records(inner):
                op = h["op"]
                if op == bytes([_OP_CONNECTION]):
                    cid = struct.unpack("<I", h["conn"])[0]
                    if cid in conns:
                        continue
                    f = _bag_fields(d)
                    pkg, _, name = f["type"].decode().partition("/")
                    conns[cid] = writer.add_connection(
                        h["topic"].decode(),
                        f"{pkg}/msg/{name}",
                        msgdef=f["message_definition"].decode(),
                        md5sum=f["md5sum"].decode(),
                        latching=int(f.get("latching", b"0") or b"0"),
                    )
                    topics[cid] = h["topic"].decode()
                elif op == bytes([_OP_MSG_DATA]):
                    cid = struct.unpack("<I", h["conn"])[0]
                    if cid not in conns:
                        continue
                    secs, nsecs = struct.unpack("<II", h["time"])
                    writer.write(conns[cid], secs * 10**9 + nsecs, d)
                    counts[topics[cid]] = counts.get(topics[cid], 0) + 1
    finally:
        writer.close()
    return counts
