"""Wire encodings of rosbridge v2 operations: JSON text, CBOR, PNG and fragments (layer 4).

- JSON: compact, never `NaN` (JavaScript's JSON.parse rejects it): non-finite floats
  become `null`, as `robotrial.msgs` does for typed messages.
- CBOR (`compression: "cbor"`): one binary frame; numeric arrays as RFC 8746 typed
  arrays, `uint8[]` as a byte string.
- PNG (`compression: "png"`): the JSON text packed into the pixels of an RGB image,
  padded with newlines, base64 in `{"op": "png", "data": ...}` (rosbridge's scheme,
  which roslibjs decodes through a canvas).
- Fragments: a JSON text longer than `fragment_size` is cut into
  `{"op": "fragment", "id", "data", "num", "total"}` pieces; `Reassembly` joins
  incoming ones.
"""

from __future__ import annotations

import base64
import io
import json
import math
from typing import Any

import orjson
from PIL import Image

from robotrial.msgs import cbor


class ProtocolError(ValueError):
    """A client's operation cannot be carried out; the text goes back in a status message."""


def _sanitize(obj: Any) -> Any:
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _sanitize(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_sanitize(v) for v in obj]
    return obj


MAX_DEPTH = 64  # nesting of objects and arrays a client may send


def check_depth(value: Any, where: str, limit: int = MAX_DEPTH) -> None:
    """Refuse data nested deeper than `limit` (it would have to be re-encoded for others)."""
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict):
            children = item.values()
        elif isinstance(item, list | tuple):
            children = item
        else:
            continue
        if depth > limit:
            raise ProtocolError(f"{where} is nested deeper than {limit} levels")
        stack.extend((c, depth + 1) for c in children)


def dumps(op: dict[str, Any]) -> str:
    """Compact JSON text of an operation; non-finite floats written as null. orjson
    writes a trajectory's floats about ten times faster than the json module."""
    try:
        return orjson.dumps(op).decode()
    except TypeError:  # what orjson does not take (integers past 64 bits, odd keys)
        return json.dumps(_sanitize(op), separators=(",", ":"), allow_nan=False)


def loads(data: str | bytes) -> Any:
    """Parse one incoming frame: JSON text, or CBOR when binary and not JSON."""
    if isinstance(data, bytes | bytearray | memoryview):
        raw = bytes(data)
        head = raw.lstrip()[:1]
        if head in (b"{", b"["):
            try:
                return json.loads(raw.decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise ProtocolError(f"invalid JSON: {exc}") from None
            except RecursionError:
                raise ProtocolError("invalid JSON: nested too deeply") from None
        try:
            return cbor.loads(raw)
        except RecursionError:
            raise ProtocolError("CBOR nested too deeply") from None
        except Exception as exc:
            raise ProtocolError(f"binary frame is neither JSON nor valid CBOR: {exc}") from None
    try:
        return json.loads(data)
    except json.JSONDecodeError as exc:
        raise ProtocolError(f"invalid JSON: {exc}") from None
    except RecursionError:
        raise ProtocolError("invalid JSON: nested too deeply") from None


def png_pack(text: str) -> str:
    """Base64 PNG whose RGB pixels hold `text` (UTF-8), padded with newlines."""
    raw = text.encode("utf-8")
    pixels = max(1, math.ceil(len(raw) / 3))
    width = max(1, math.isqrt(pixels))
    height = math.ceil(pixels / width)
    raw += b"\n" * (width * height * 3 - len(raw))
    buf = io.BytesIO()
    Image.frombytes("RGB", (width, height), raw).save(buf, format="PNG")
    return base64.b64encode(buf.getvalue()).decode("ascii")


def png_unpack(data: str) -> str:
    """The text inside a `png_pack` image (trailing padding removed)."""
    try:
        img = Image.open(io.BytesIO(base64.b64decode(data, validate=True)))
        img.load()
        raw = img.convert("RGB").tobytes()
    except Exception as exc:
        raise ProtocolError(f"png data is not a valid base64 PNG: {exc}") from None
    return raw.rstrip(b"\n").decode("utf-8", errors="replace")


def encode_op(op: dict[str, Any], compression: str) -> str | bytes:
    """One operation as a WebSocket frame: text (JSON, PNG) or binary (CBOR)."""
    if compression == "cbor":
        return cbor.dumps(op)
    text = dumps(op)
    if compression == "png":
        return dumps({"op": "png", "data": png_pack(text)})
    return text


def fragments(frame: str, fragment_size: int, fragment_id: str) -> list[str]:
    """`frame` itself, or fragment operations of at most `fragment_size` characters."""
    if fragment_size <= 0 or len(frame) <= fragment_size:
        return [frame]
    total = math.ceil(len(frame) / fragment_size)
    return [
        dumps(
            {
                "op": "fragment",
                "id": fragment_id,
                "data": frame[i * fragment_size : (i + 1) * fragment_size],
                "num": i,
                "total": total,
            }
        )
        for i in range(total)
    ]


class Reassembly:
    """Collects incoming fragments per id; bounded in ids, pieces and characters."""

    def __init__(self, max_chars: int, max_ids: int = 32) -> None:
        self.max_chars = max_chars
        self.max_ids = max_ids
        self._parts: dict[str, dict[int, str]] = {}
        self._sizes: dict[str, int] = {}

    def add(self, op: dict[str, Any]) -> str | None:
        """Store one fragment; the whole text when the last piece has arrived."""
        fid, data, num, total = op.get("id"), op.get("data"), op.get("num"), op.get("total")
        if not isinstance(fid, str | int) or isinstance(fid, bool):
            raise ProtocolError("fragment: 'id' must be a string or an integer")
        if not isinstance(data, str):
            raise ProtocolError("fragment: 'data' must be a string")
        if type(num) is not int or type(total) is not int or not 0 <= num < total:
            raise ProtocolError("fragment: 'num' and 'total' must be integers, 0 <= num < total")
        key = str(fid)
        if key not in self._parts:
            if len(self._parts) >= self.max_ids:
                oldest = next(iter(self._parts))
                self.drop(oldest)
            self._parts[key] = {}
            self._sizes[key] = 0
        parts = self._parts[key]
        size = self._sizes[key] + len(data) - len(parts.get(num, ""))
        if size > self.max_chars or total > self.max_chars:
            self.drop(key)
            raise ProtocolError(f"fragment {key}: message larger than {self.max_chars} characters")
        parts[num] = data
        self._sizes[key] = size
        if len(parts) < total:
            return None
        self.drop(key)
        if set(parts) != set(range(total)):
            raise ProtocolError(f"fragment {key}: pieces do not match total {total}")
        return "".join(parts[i] for i in range(total))

    def drop(self, key: str) -> None:
        self._parts.pop(key, None)
        self._sizes.pop(key, None)

    def pending(self) -> int:
        return len(self._parts)
