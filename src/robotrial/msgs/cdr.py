"""Binary ROS serializations, for rosbridge's `cbor-raw`: ROS 2 CDR and ROS 1.

The bytes are what a ROS 2 node puts on the wire: a 4-byte encapsulation header
(`00 01 00 00`), then the fields in order, each primitive aligned to its own size
(counted from after the header), strings and sequences prefixed with a uint32 length.
An empty message carries one zero byte, as rosidl generates. `serialize_ros1` writes
the ROS 1 format for clients that asked in the ROS 1 dialect.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

from robotrial.msgs.core import BYTE_TYPES, NUMPY_DTYPES, FieldSpec, Message, MessageError

_FORMAT = {
    "bool": "?",
    "byte": "B",
    "char": "B",
    "int8": "b",
    "uint8": "B",
    "int16": "<h",
    "uint16": "<H",
    "int32": "<i",
    "uint32": "<I",
    "int64": "<q",
    "uint64": "<Q",
    "float32": "<f",
    "float64": "<d",
}
_SIZE = {k: struct.calcsize(v) for k, v in _FORMAT.items()}


class _Writer:
    def __init__(self) -> None:
        self.buf = bytearray(b"\x00\x01\x00\x00")

    def align(self, n: int) -> None:
        pad = (-(len(self.buf) - 4)) % n
        if pad:
            self.buf += bytes(pad)

    def prim(self, base: str, value: Any) -> None:
        self.align(_SIZE[base])
        self.buf += struct.pack(_FORMAT[base], value)

    def string(self, value: str) -> None:
        raw = value.encode("utf-8")
        self.prim("uint32", len(raw) + 1)
        self.buf += raw + b"\x00"


def _field(w: _Writer, spec: FieldSpec, value: Any) -> None:
    if spec.array is None:
        if spec.msg is not None:
            _message(w, value)
        elif spec.base == "string":
            w.string(value)
        else:
            w.prim(spec.base, value)
        return
    if spec.array < 0:
        w.prim("uint32", len(value))
    if spec.msg is not None:
        for item in value:
            _message(w, item)
    elif spec.base == "string":
        for item in value:
            w.string(item)
    elif spec.base in BYTE_TYPES:
        w.buf += bytes(value) if not isinstance(value, np.ndarray) else value.tobytes()
    elif spec.base == "bool":
        w.buf += bytes(bool(v) for v in value)
    else:
        dtype = np.dtype(NUMPY_DTYPES[spec.base])
        if len(value):
            w.align(dtype.itemsize)
        w.buf += np.asarray(value, dtype=dtype).tobytes()


def _message(w: _Writer, msg: Message) -> None:
    specs = type(msg).__fields_spec__
    if not specs:
        w.buf += b"\x00"
        return
    for spec in specs:
        _field(w, spec, getattr(msg, spec.name))


def serialize(msg: Any) -> bytes:
    """CDR bytes of a message instance (plain dicts have no known layout)."""
    if not isinstance(msg, Message):
        raise MessageError(f"CDR needs a message of a known type, got {type(msg).__name__}")
    w = _Writer()
    try:
        _message(w, msg)
    except struct.error as exc:
        raise MessageError(
            f"{type(msg).__ros_type__}: value does not fit its type: {exc}"
        ) from None
    return bytes(w.buf)


# ---------------------------------------------------------------- ROS 1


def _ros1_field(buf: bytearray, spec: FieldSpec, value: Any) -> None:
    if spec.msg is not None:
        items = [value] if spec.array is None else value
        if spec.array is not None and spec.array < 0:
            buf += struct.pack("<I", len(items))
        for item in items:
            _ros1_message(buf, item)
        return
    if spec.array is None:
        if spec.base == "string":
            raw = value.encode("utf-8")
            buf += struct.pack("<I", len(raw)) + raw
        else:
            buf += struct.pack(_FORMAT[spec.base], value)
        return
    if spec.array < 0:
        buf += struct.pack("<I", len(value))
    if spec.base == "string":
        for item in value:
            raw = item.encode("utf-8")
            buf += struct.pack("<I", len(raw)) + raw
    elif spec.base in BYTE_TYPES:
        buf += bytes(value) if not isinstance(value, np.ndarray) else value.tobytes()
    elif spec.base == "bool":
        buf += bytes(bool(v) for v in value)
    else:
        buf += np.asarray(value, dtype=NUMPY_DTYPES[spec.base]).tobytes()


def _ros1_message(buf: bytearray, msg: Message) -> None:
    cls = type(msg)
    r1 = cls.__ros1__
    if r1.primitive:
        # ROS 1 time: uint32 secs, uint32 nsecs; duration: int32 secs, int32 nsecs
        fmt = "<II" if r1.primitive == "time" else "<ii"
        buf += struct.pack(fmt, msg.sec, msg.nanosec)  # type: ignore[attr-defined]
        return
    for _, (rtype, value) in r1.extra.items():
        buf += struct.pack(_FORMAT[rtype], value)
    for spec in cls.__fields_spec__:
        if spec.name not in r1.drop:
            _ros1_field(buf, spec, getattr(msg, spec.name))


def serialize_ros1(msg: Any) -> bytes:
    """ROS 1 serialization of a message instance (what `rosbag` and rospy write):
    little-endian, unaligned, length-prefixed strings and arrays, `seq` in headers."""
    if not isinstance(msg, Message):
        raise MessageError(f"ROS 1 serialization needs a known type, got {type(msg).__name__}")
    buf = bytearray()
    try:
        _ros1_message(buf, msg)
    except struct.error as exc:
        raise MessageError(
            f"{type(msg).__ros_type__}: value does not fit its type: {exc}"
        ) from None
    return bytes(buf)
