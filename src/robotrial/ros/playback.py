"""Playback of a recording into the bus or a loop (layer 4).

Recordings read: MCAP files, ROS 1 .bag files, and ROS 2 bags (a folder with
`metadata.yaml`, sqlite3 or MCAP storage, as `ros2 bag record` writes them, or a bare
`.db3`). `read_recording` yields (topic, message, time) in log-time order, with messages
as robotrial.msgs dataclasses, so a recorded run feeds the same consumers (SLAM, the web
page, tests) as the live simulator; `play` publishes them on a bus, as fast as possible or
paced. `contents` lists topics, types and message counts from a recording's index,
without decoding a message, so types robotrial does not know are listed too.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

from mcap.reader import make_reader
from rosbags.rosbag1 import Reader as Bag1Reader
from rosbags.rosbag2 import Reader as Bag2Reader

from robotrial.msgs import Message
from robotrial.ros.bus import Bus
from robotrial.ros.recorder import deserialize
from robotrial.sim.scene import Pacer


def recording_kind(path: str | Path) -> str:
    """ "mcap", "bag" (ROS 1) or "rosbag2" (a ROS 2 bag folder or a .db3 file); a clear
    error for a path that is none of these."""
    p = Path(path)
    if p.is_dir():
        if (p / "metadata.yaml").is_file():
            return "rosbag2"
        raise ValueError(f"{p}: a folder is a ROS 2 bag only with a metadata.yaml in it")
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such recording")
    kinds = {".mcap": "mcap", ".bag": "bag", ".db3": "rosbag2"}
    if p.suffix.lower() not in kinds:
        raise ValueError(
            f"{p}: a recording is a .mcap, a ROS 1 .bag, a ROS 2 .db3 or a ROS 2 bag folder"
        )
    return kinds[p.suffix.lower()]


def read_recording(
    path: str | Path, topics: Iterable[str] | None = None
) -> Iterator[tuple[str, Message, float]]:
    """(topic, message, log time in s) of every message, optionally only some topics."""
    p = Path(path)
    fmt = recording_kind(p)
    wanted = None if topics is None else set(topics)
    if fmt == "rosbag2":
        with Bag2Reader(p) as reader:
            conns = [c for c in reader.connections if wanted is None or c.topic in wanted]
            for conn, stamp, raw in reader.messages(connections=conns):
                yield conn.topic, deserialize(raw, conn.msgtype, "ros2"), stamp * 1e-9
        return
    if fmt == "mcap":
        with open(p, "rb") as f:
            reader = make_reader(f)
            for schema, channel, message in reader.iter_messages(
                topics=None if wanted is None else sorted(wanted), log_time_order=True
            ):
                if schema is None or channel.message_encoding != "cdr":
                    continue
                msg = deserialize(message.data, schema.name, "ros2")
                yield channel.topic, msg, message.log_time * 1e-9
        return
    with Bag1Reader(p) as reader:
        conns = [c for c in reader.connections if wanted is None or c.topic in wanted]
        for conn, stamp, raw in reader.messages(connections=conns):
            yield conn.topic, deserialize(raw, conn.msgtype, "ros1"), stamp * 1e-9


def contents(path: str | Path) -> dict[str, tuple[str, int]]:
    """topic -> (type, messages) from the recording's index; nothing is decoded."""
    p = Path(path)
    fmt = recording_kind(p)
    out: dict[str, tuple[str, int]] = {}

    def add(topic: str, type_name: str, n: int) -> None:
        out[topic] = (type_name, out.get(topic, ("", 0))[1] + n)

    if fmt == "mcap":
        with open(p, "rb") as f:
            s = make_reader(f).get_summary()
        if s is None or s.statistics is None:
            raise ValueError(
                f"{p} has no index (cut short?); try: robotrial bag recover {p} -o FIXED.mcap"
            )
        counts = s.statistics.channel_message_counts
        for cid, ch in s.channels.items():
            schema = s.schemas.get(ch.schema_id)
            add(ch.topic, schema.name if schema else "", counts.get(cid, 0))
        return dict(sorted(out.items()))
    reader_cls = Bag1Reader if fmt == "bag" else Bag2Reader
    with reader_cls(p) as reader:
        for c in reader.connections:
            add(c.topic, c.msgtype, c.msgcount)
    return dict(sorted(out.items()))


def summary(path: str | Path) -> dict[str, int]:
    """Messages per topic in a recording (from its index)."""
    return {topic: n for topic, (_, n) in contents(path).items()}


def play(
    path: str | Path,
    bus: Bus,
    topics: Iterable[str] | None = None,
    rate: float | None = None,
) -> int:
    """Publish a recording on `bus` (at `rate` x recorded speed, or as fast as possible);
    returns the number of messages published."""
    pacer = Pacer(rate)
    n = 0
    for topic, msg, t in read_recording(path, topics):
        pacer.wait(t)
        bus.publish(topic, msg)
        n += 1
    return n
