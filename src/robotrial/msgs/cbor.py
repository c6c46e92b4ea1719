"""CBOR for rosbridge's `cbor` compression: numeric arrays as RFC 8746 typed arrays.

`Message.to_wire()` leaves numeric arrays as little-endian numpy arrays and `uint8[]` as
bytes; `dumps` writes those arrays with the RFC 8746 tags that roslibjs decodes into
JavaScript typed arrays (rosbridge_suite does the same). `loads` turns typed-array tags
back into lists, so a client may send CBOR too.
"""

from __future__ import annotations

from typing import Any

import cbor2
import numpy as np

# numpy dtype (little-endian) -> RFC 8746 tag
_TAG_OF: dict[str, int] = {
    "|u1": 64,
    "<u2": 69,
    "<u4": 70,
    "<u8": 71,
    "|i1": 72,
    "<i2": 77,
    "<i4": 78,
    "<i8": 79,
    "<f4": 85,
    "<f8": 86,
}
_DTYPE_OF: dict[int, str] = {tag: dt for dt, tag in _TAG_OF.items()}
# the big-endian tags, for clients that send them
_DTYPE_OF.update({65: ">u2", 66: ">u4", 67: ">u8", 73: ">i2", 74: ">i4", 75: ">i8"})
_DTYPE_OF.update({81: ">f4", 82: ">f8", 84: "<f2", 80: ">f2"})


def _default(encoder: cbor2.CBOREncoder, value: Any) -> None:
    if isinstance(value, np.ndarray):
        arr = np.ascontiguousarray(value)
        if arr.dtype.byteorder == ">":
            arr = arr.astype(arr.dtype.newbyteorder("<"))
        tag = _TAG_OF.get(arr.dtype.str)
        if tag is None:
            encoder.encode(arr.tolist())
        else:
            encoder.encode(cbor2.CBORTag(tag, arr.tobytes()))
        return
    if isinstance(value, np.generic):
        encoder.encode(value.item())
        return
    raise cbor2.CBOREncodeError(f"cannot encode {type(value).__name__} as CBOR")


def dumps(obj: Any) -> bytes:
    """CBOR bytes of a rosbridge operation whose message came from `to_wire()`."""
    return cbor2.dumps(obj, default=_default)


def _tag_hook(*args: Any) -> Any:
    # cbor2 5 calls hook(decoder, tag), cbor2 6 calls hook(tag, immutable)
    tag = next(a for a in args if isinstance(a, cbor2.CBORTag))
    dtype = _DTYPE_OF.get(tag.tag)
    if dtype is not None and isinstance(tag.value, bytes):
        if dtype == "|u1":
            return tag.value
        width = np.dtype(dtype).itemsize
        if len(tag.value) % width:
            raise ValueError(f"typed array tag {tag.tag}: {len(tag.value)} bytes is not whole")
        return np.frombuffer(tag.value, dtype=dtype).tolist()
    return tag


def loads(data: bytes) -> Any:
    """Decode CBOR; typed arrays become lists (uint8 arrays stay bytes)."""
    return cbor2.loads(data, tag_hook=_tag_hook)
