"""Playback of a recording (.mcap or ROS 1 .bag) into the bus or a loop (layer 4).

`read_recording` yields (topic, message, time) in log-time order, with messages as
robotrial.msgs dataclasses, so a recorded run feeds the same consumers (SLAM, the web
page, tests) as the live simulator. `play` publishes them on a bus, as fast as possible
or paced.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

from mcap.reader import make_reader
from rosbags.rosbag1 import Reader as Bag1Reader

from robotrial.msgs import Message
from robotrial.ros.bus import Bus
from robotrial.ros.recorder import deserialize, format_of
from robotrial.sim.scene import Pacer


def read_recording(
    path: str | Path, topics: Iterable[str] | None = None
) -> Iterator[tuple[str, Message, float]]:
    """(topic, message, log time in s) of every message, optionally only some topics."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such recording")
    fmt = format_of(p)
    wanted = None if topics is None else set(topics)
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


def summary(path: str | Path) -> dict[str, int]:
    """Messages per topic in a recording."""
    counts: dict[str, int] = {}
    for topic, _, _ in read_recording(path):
        counts[topic] = counts.get(topic, 0) + 1
    return counts


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
