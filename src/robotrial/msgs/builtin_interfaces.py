"""builtin_interfaces: Time and Duration (ROS 2 `sec`/`nanosec`; ROS 1 `secs`/`nsecs`)."""

from __future__ import annotations

from robotrial.msgs.core import Message, Ros1Spelling, int32, message, now_ns, uint32

_ROS1_TIME = {"sec": "secs", "nanosec": "nsecs"}


@message(
    "builtin_interfaces/msg/Time",
    ros1=Ros1Spelling(rename=_ROS1_TIME, primitive="time"),
)
class Time(Message):
    """A point in time: seconds and nanoseconds since the epoch (or since sim start)."""

    sec: int32
    nanosec: uint32

    @staticmethod
    def from_sec(t: float) -> Time:
        ns = round(t * 1e9)
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    @staticmethod
    def now() -> Time:
        """The time of the clock in force (`core.use_clock`; wall time by default)."""
        ns = now_ns()
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def to_sec(self) -> float:
        return self.sec + self.nanosec * 1e-9


@message(
    "builtin_interfaces/msg/Duration",
    ros1=Ros1Spelling(rename=_ROS1_TIME, primitive="duration"),
)
class Duration(Message):
    """A span of time; `nanosec` is always in [0, 1e9), negative spans have negative `sec`."""

    sec: int32
    nanosec: uint32

    @staticmethod
    def from_sec(t: float) -> Duration:
        ns = round(t * 1e9)
        return Duration(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def to_sec(self) -> float:
        return self.sec + self.nanosec * 1e-9
