"""ROS 2 CDR serialization (little-endian, XCDR1), for rosbridge's `cbor-raw` and bags.

The bytes are what a ROS 2 node puts on the wire: a 4-byte encapsulation header
(`00 01 00 00`), then the fields in order, each primitive aligned to its own size
(counted from after the header), strings and sequences prefixed with a uint32 length.
An empty message carries one zero byte, as rosidl generates.
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
