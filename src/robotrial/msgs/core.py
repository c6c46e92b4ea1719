"""The machinery behind every message type: field specs, registry, rosbridge JSON (layer 0).

A message is a dataclass decorated with `@message("pkg/msg/Name")`. Its annotations are
the single source of truth: ROS field types come from the aliases below (`float64`,
`list[string]`, `fixed(float64, 9)`, `uint8_array`, a nested message class), and from
them follow defaults, JSON conversion, `.msg` definition text, rosapi type details and
the generated TypeScript interfaces.

Spelling. Internally everything is ROS 2: type names `sensor_msgs/msg/LaserScan`, time
as `builtin_interfaces/msg/Time` with `sec`/`nanosec`, no `Header.seq`. On the wire a
`dialect` chooses the spelling: "ros2" (default) or "ros1" (`secs`/`nsecs`, `seq`, the
ROS 1 field names of CameraInfo, no ROS 2-only Marker fields). Input accepts both.

JSON follows rosbridge: `uint8[]`/`char[]` as base64 strings (lists of ints are
accepted too), non-finite floats as `null` (JSON has no NaN; `null` reads back as NaN),
missing fields take their defaults, unknown fields are an error.
"""

from __future__ import annotations

import base64
import binascii
import dataclasses
import importlib
import inspect
import math
import re
import time as _time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, get_args, get_origin, get_type_hints

import numpy as np

# ROS primitive types as Python annotations. The string is the ROS type.
bool_ = Annotated[bool, "bool"]
byte = Annotated[int, "byte"]
char = Annotated[int, "char"]
int8 = Annotated[int, "int8"]
uint8 = Annotated[int, "uint8"]
int16 = Annotated[int, "int16"]
uint16 = Annotated[int, "uint16"]
int32 = Annotated[int, "int32"]
uint32 = Annotated[int, "uint32"]
int64 = Annotated[int, "int64"]
uint64 = Annotated[int, "uint64"]
float32 = Annotated[float, "float32"]
float64 = Annotated[float, "float64"]
string = Annotated[str, "string"]
# uint8[] travels as bytes (base64 in JSON, raw in CBOR), as in rosbridge.
uint8_array = Annotated[bytes, "uint8[]"]

# The clock that "now" (a time field's value in rosbridge JSON) and `Time.now()` read, in
# nanoseconds: wall time unless a caller runs under `use_clock` (a simulation's time).
_NOW_NS: ContextVar[Callable[[], int]] = ContextVar("now_ns", default=_time.time_ns)


def now_ns() -> int:
    """The current time (ns) of the clock in force (see `use_clock`)."""
    return _NOW_NS.get()()


@contextmanager
def use_clock(clock_ns: Callable[[], int]) -> Iterator[None]:
    """Within the block (this thread or task), "now" and `Time.now()` read `clock_ns`."""
    token = _NOW_NS.set(clock_ns)
    try:
        yield
    finally:
        _NOW_NS.reset(token)


Dialect = str  # "ros2" or "ros1"
DIALECTS = ("ros2", "ros1")

INT_RANGES: dict[str, tuple[int, int]] = {
    "byte": (0, 255),
    "char": (0, 255),
    "int8": (-(2**7), 2**7 - 1),
    "uint8": (0, 2**8 - 1),
    "int16": (-(2**15), 2**15 - 1),
    "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1),
    "uint64": (0, 2**64 - 1),
}
FLOAT_TYPES = ("float32", "float64")
BYTE_TYPES = ("uint8", "char", "byte")
PRIMITIVES = (*INT_RANGES, *FLOAT_TYPES, "bool", "string")
NUMPY_DTYPES: dict[str, str] = {
    "byte": "u1",
    "char": "u1",
    "int8": "i1",
    "uint8": "u1",
    "int16": "<i2",
    "uint16": "<u2",
    "int32": "<i4",
    "uint32": "<u4",
    "int64": "<i8",
    "uint64": "<u8",
    "float32": "<f4",
    "float64": "<f8",
}


class MessageError(ValueError):
    """A message (or its JSON) does not fit its type; the text names the field path."""


def fixed(element: Any, length: int) -> Any:
    """The annotation of a fixed-size array, e.g. `fixed(float64, 36)` for float64[36]."""
    (ros,) = element.__metadata__
    py = get_args(element)[0]
    return Annotated[list[py], f"{ros}[{length}]"]


@dataclass(frozen=True)
class FieldSpec:
    """One field of a message: its name and ROS type.

    `base` is a primitive name or a message type name; `msg` the nested class (or None);
    `array` is None for a scalar, -1 for an unbounded array, n for a fixed one.
    """

    name: str
    base: str
    msg: type | None
    array: int | None

    @property
    def is_bytes(self) -> bool:
        return self.array is not None and self.msg is None and self.base in BYTE_TYPES

    def ros_type(self, dialect: Dialect = "ros2") -> str:
        """The type as written in a .msg file, e.g. `float64[9]`, `geometry_msgs/Pose[]`."""
        if self.msg is None:
            base = self.base
        else:
            base = definition_name(self.msg.__ros_type__, dialect)
        if self.array is None:
            return base
        return f"{base}[{'' if self.array < 0 else self.array}]"

    def default(self) -> Any:
        if self.array is not None:
            if self.is_bytes:
                return bytes(max(self.array, 0))
            if self.array > 0:
                item = self.msg() if self.msg is not None else _primitive_default(self.base)
                if self.msg is not None:
                    return [self.msg() for _ in range(self.array)]
                return [item] * self.array
            return []
        if self.msg is not None:
            return self.msg()
        return _primitive_default(self.base)


def _primitive_default(base: str) -> Any:
    if base == "bool":
        return False
    if base == "string":
        return ""
    if base in FLOAT_TYPES:
        return 0.0
    return 0


@dataclass(frozen=True)
class Ros1Spelling:
    """How a type differs in ROS 1: renamed fields, ROS 2-only fields, ROS 1-only extras."""

    rename: Mapping[str, str] = dataclasses.field(default_factory=dict)
    drop: tuple[str, ...] = ()
    extra: Mapping[str, tuple[str, Any]] = dataclasses.field(default_factory=dict)
    primitive: str | None = None  # "time" / "duration": a builtin type in ROS 1


class Message:
    """Base of every message dataclass; the class attributes are filled by `@message`."""

    __ros_type__: ClassVar[str]
    __fields_spec__: ClassVar[tuple[FieldSpec, ...]]
    __field_map__: ClassVar[dict[str, FieldSpec]]
    __constants__: ClassVar[tuple[tuple[str, str, Any], ...]]
    __ros1__: ClassVar[Ros1Spelling]
    __aliases__: ClassVar[dict[str, str]]

    def to_dict(self, dialect: Dialect = "ros2") -> dict[str, Any]:
        """The rosbridge JSON object (plain dicts, lists, numbers, strings)."""
        return _encode(self, dialect, False)

    def to_wire(self, dialect: Dialect = "ros2") -> dict[str, Any]:
        """Like `to_dict` but for binary encodings: bytes stay bytes, numeric arrays become
        little-endian numpy arrays (CBOR writes them as RFC 8746 typed arrays)."""
        return _encode(self, dialect, True)

    @classmethod
    def from_dict(cls, data: Any, path: str | None = None) -> Any:
        """Build the message from rosbridge JSON (either dialect); raise MessageError
        naming the field path when something does not fit."""
        return _decode(cls, data, path or cls.__ros_type__)


# type name (canonical ROS 2 spelling) -> class; service name -> ServiceType
MESSAGES: dict[str, type[Message]] = {}
SERVICES: dict[str, ServiceType] = {}
ACTIONS: dict[str, ActionType] = {}


@dataclass(frozen=True)
class ServiceType:
    """A service: its type name and request/response message classes."""

    name: str
    Request: type[Message]
    Response: type[Message]

    @property
    def ros1_name(self) -> str:
        return ros1_name(self.name)


@dataclass(frozen=True)
class ActionType:
    """An action: its type name and goal/result/feedback message classes."""

    name: str
    Goal: type[Message]
    Result: type[Message]
    Feedback: type[Message]


def ros1_name(name: str) -> str:
    """`sensor_msgs/msg/LaserScan` -> `sensor_msgs/LaserScan` (unchanged when already so)."""
    parts = name.split("/")
    if len(parts) == 3:
        return f"{parts[0]}/{parts[2]}"
    return name


def definition_name(name: str, dialect: Dialect = "ros2") -> str:
    """How a nested type is written inside a .msg file (`std_msgs/Header`, ROS 1 `time`)."""
    cls = MESSAGES.get(name)
    if dialect == "ros1" and cls is not None and cls.__ros1__.primitive:
        return cls.__ros1__.primitive
    return ros1_name(name)


# rosapi's ROS 1 package is `rosapi`, its ROS 2 package `rosapi_msgs`.
_PACKAGE_ALIASES = {"rosapi": "rosapi_msgs"}


def _key(name: str) -> tuple[str, str]:
    parts = [p for p in name.strip().split("/") if p]
    if len(parts) == 3:
        pkg, name_ = parts[0], parts[2]
    elif len(parts) == 2:
        pkg, name_ = parts
    else:
        return ("", name.strip())
    return (_PACKAGE_ALIASES.get(pkg, pkg), name_)


_MSG_INDEX: dict[tuple[str, str], type[Message]] = {}
_SRV_INDEX: dict[tuple[str, str], ServiceType] = {}
_ACTION_INDEX: dict[tuple[str, str], ActionType] = {}


PACKAGES = (
    "builtin_interfaces",
    "control_msgs",
    "geometry_msgs",
    "nav2_msgs",
    "nav_msgs",
    "robotrial_msgs",
    "rosapi",
    "rosgraph_msgs",
    "sensor_msgs",
    "std_msgs",
    "std_srvs",
    "tf2_msgs",
    "tf2_web_republisher",
    "trajectory_msgs",
    "visualization_msgs",
)
"""The modules of `robotrial.msgs` that define types, one per ROS package."""

_all_loaded = False


def load_all() -> None:
    """Import every package's module, registering all types. A module is imported when
    first used, so that a command needing a few types does not build them all; a lookup
    by name, and `robotrial.msgs.MESSAGES`, load the rest."""
    global _all_loaded
    if not _all_loaded:
        for package in PACKAGES:
            importlib.import_module(f"robotrial.msgs.{package}")
        _all_loaded = True


def _find(index: dict[tuple[str, str], Any], name: str) -> Any:
    key = _key(name)
    if key not in index:
        load_all()
    return index.get(key)


def lookup_message(name: str) -> type[Message] | None:
    """The message class for a type name in any spelling (`pkg/Name`, `pkg/msg/Name`,
    ROS 1 `time`/`duration`), or None when the type is not known here."""
    if name == "time":
        name = "builtin_interfaces/msg/Time"
    elif name == "duration":
        name = "builtin_interfaces/msg/Duration"
    return _find(_MSG_INDEX, name)


def lookup_service(name: str) -> ServiceType | None:
    """The service type for a name in any spelling (`pkg/Name`, `pkg/srv/Name`)."""
    return _find(_SRV_INDEX, name)


def lookup_action(name: str) -> ActionType | None:
    """The action type for a name in any spelling (`pkg/Name`, `pkg/action/Name`)."""
    return _find(_ACTION_INDEX, name)


def type_dialect(name: str | None) -> Dialect | None:
    """The dialect a client's type spelling implies: `pkg/msg/X` -> ros2, `pkg/X` -> ros1."""
    if not name or not isinstance(name, str):
        return None
    return "ros2" if name.count("/") >= 2 else "ros1"


def _parse_hint(name: str, hint: Any, owner: str) -> FieldSpec:
    if get_origin(hint) is Annotated:
        meta = hint.__metadata__[0]
        m = re.fullmatch(r"(\w+)(?:\[(\d*)\])?", str(meta))
        if not m or m.group(1) not in PRIMITIVES:
            raise TypeError(f"{owner}.{name}: unknown ROS type annotation {meta!r}")
        arr = m.group(2)
        array = None if arr is None else (int(arr) if arr else -1)
        return FieldSpec(name, m.group(1), None, array)
    if get_origin(hint) is list:
        inner = _parse_hint(name, get_args(hint)[0], owner)
        if inner.array is not None:
            raise TypeError(f"{owner}.{name}: arrays of arrays do not exist in ROS")
        return dataclasses.replace(inner, array=-1)
    if isinstance(hint, type) and issubclass(hint, Message):
        return FieldSpec(name, hint.__ros_type__, hint, None)
    raise TypeError(f"{owner}.{name}: annotation {hint!r} is not a ROS type")


def _default(spec: FieldSpec) -> Any:
    """A field's dataclass default: the value itself when immutable (no call per
    message made), else the cheapest factory of a fresh one."""
    value = spec.default()
    if isinstance(value, bool | int | float | str | bytes):
        return value
    if spec.array is not None and spec.array < 0:
        return dataclasses.field(default_factory=list)
    if spec.array is None and spec.msg is not None:
        return dataclasses.field(default_factory=spec.msg)
    return dataclasses.field(default_factory=spec.default)


def message(
    type_name: str,
    *,
    ros1: Ros1Spelling | None = None,
) -> Callable[[type], type]:
    """Class decorator: make a ROS message dataclass named `type_name` (ROS 2 spelling).

    Fields without a default get the ROS default (0, "", [], nested default message).
    `ClassVar` annotations with a value are ROS constants.
    """

    def wrap(cls: type) -> type:
        if not issubclass(cls, Message):
            raise TypeError(f"{cls.__name__}: a message class must subclass Message")
        hints = get_type_hints(cls, include_extras=True)
        own = inspect.get_annotations(cls)
        specs: list[FieldSpec] = []
        consts: list[tuple[str, str, Any]] = []
        for name in own:
            hint = hints[name]
            if get_origin(hint) is ClassVar:
                if name.startswith("__"):
                    continue
                spec = _parse_hint(name, get_args(hint)[0], type_name)
                consts.append((name, spec.base, getattr(cls, name)))
                continue
            spec = _parse_hint(name, hint, type_name)
            specs.append(spec)
            if name not in cls.__dict__:
                setattr(cls, name, _default(spec))
        cls.__ros_type__ = type_name
        cls.__fields_spec__ = tuple(specs)
        cls.__field_map__ = {s.name: s for s in specs}
        cls.__constants__ = tuple(consts)
        cls.__ros1__ = ros1 or Ros1Spelling()
        aliases = {v: k for k, v in cls.__ros1__.rename.items()}
        cls.__aliases__ = aliases
        out = dataclass(cls)
        MESSAGES[type_name] = out
        _MSG_INDEX[_key(type_name)] = out
        return out

    return wrap


def service(type_name: str, request: type[Message], response: type[Message]) -> ServiceType:
    """Register a service type (ROS 2 spelling `pkg/srv/Name`) from its two messages."""
    srv = ServiceType(type_name, request, response)
    SERVICES[type_name] = srv
    _SRV_INDEX[_key(type_name)] = srv
    return srv


def action(
    type_name: str, goal: type[Message], result: type[Message], feedback: type[Message]
) -> ActionType:
    """Register an action type (ROS 2 spelling `pkg/action/Name`) from its three messages."""
    act = ActionType(type_name, goal, result, feedback)
    ACTIONS[type_name] = act
    _ACTION_INDEX[_key(type_name)] = act
    return act


# ---------------------------------------------------------------- encoding


def _finite_list(values: list) -> list:
    if all(map(math.isfinite, values)):
        return values
    return [v if math.isfinite(v) else None for v in values]


def _encode_field(spec: FieldSpec, value: Any, dialect: Dialect, binary: bool) -> Any:
    if spec.msg is not None:
        if spec.array is None:
            return _encode(value, dialect, binary)
        return [_encode(v, dialect, binary) for v in value]
    if spec.array is None:
        if spec.base in FLOAT_TYPES:
            v = float(value)
            return v if (binary or math.isfinite(v)) else None
        if spec.base == "string":
            return str(value)
        if spec.base == "bool":
            return bool(value)
        return int(value)
    if spec.is_bytes:
        raw = value.astype(np.uint8).tobytes() if isinstance(value, np.ndarray) else bytes(value)
        return raw if binary else base64.b64encode(raw).decode("ascii")
    if spec.base in NUMPY_DTYPES:
        if binary:
            return np.asarray(value, dtype=NUMPY_DTYPES[spec.base])
        if isinstance(value, np.ndarray):
            value = value.tolist()
        if spec.base in FLOAT_TYPES:
            return _finite_list([float(v) for v in value])
        return [int(v) for v in value]
    if spec.base == "string":
        return [str(v) for v in value]
    return [bool(v) for v in value]


def encode_given(msg: Any, dialect: Dialect, given: Mapping[str, Any]) -> dict[str, Any]:
    """`msg.to_dict(dialect)`, with the fields named in `given` (field name -> their
    JSON) taken as they are: for a caller that writes a long field faster itself."""
    return _encode(msg, dialect, False, given)


def _encode(
    msg: Any, dialect: Dialect, binary: bool, given: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    if isinstance(msg, Mapping):
        return dict(msg)
    cls = type(msg)
    try:
        specs = cls.__fields_spec__
    except AttributeError:
        raise MessageError(f"{msg!r} is not a ROS message") from None
    out: dict[str, Any] = {}
    if dialect == "ros1":
        r1 = cls.__ros1__
        for key, (_, value) in r1.extra.items():
            out[key] = value
        for spec in specs:
            if spec.name in r1.drop:
                continue
            key = r1.rename.get(spec.name, spec.name)
            if given and spec.name in given:
                out[key] = given[spec.name]
            else:
                out[key] = _encode_field(spec, getattr(msg, spec.name), dialect, binary)
        return out
    for spec in specs:
        if given and spec.name in given:
            out[spec.name] = given[spec.name]
        else:
            out[spec.name] = _encode_field(spec, getattr(msg, spec.name), dialect, binary)
    return out


# ---------------------------------------------------------------- decoding


def _type_name(v: Any) -> str:
    return {dict: "object", list: "array", str: "string", bool: "boolean", type(None): "null"}.get(
        type(v), type(v).__name__
    )


def _decode_primitive(base: str, v: Any, path: str) -> Any:
    if base in FLOAT_TYPES:
        if v is None:
            return math.nan
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise MessageError(f"{path}: expected a number ({base}), got {_type_name(v)}")
        return float(v)
    if base == "string":
        if not isinstance(v, str):
            raise MessageError(f"{path}: expected a string, got {_type_name(v)}")
        return v
    if base == "bool":
        if isinstance(v, bool):
            return v
        if isinstance(v, int) and v in (0, 1):
            return bool(v)
        raise MessageError(f"{path}: expected true or false, got {_type_name(v)}")
    if isinstance(v, bool) or not isinstance(v, int):
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        else:
            raise MessageError(f"{path}: expected an integer ({base}), got {_type_name(v)}")
    lo, hi = INT_RANGES[base]
    if not lo <= v <= hi:
        raise MessageError(f"{path}: {v} is out of range for {base} [{lo}, {hi}]")
    return v


def _decode_bytes(spec: FieldSpec, v: Any, path: str) -> bytes:
    if isinstance(v, bytes | bytearray | memoryview):
        raw = bytes(v)
    elif isinstance(v, str):
        try:
            raw = base64.b64decode(v, validate=True)
        except (binascii.Error, ValueError):
            raise MessageError(f"{path}: not valid base64 for {spec.ros_type()}") from None
    elif isinstance(v, list | tuple):
        if not all(type(x) is int and 0 <= x <= 255 for x in v):
            raise MessageError(f"{path}: a {spec.ros_type()} list must hold integers 0..255")
        raw = bytes(v)
    else:
        raise MessageError(f"{path}: expected base64 text or a list of bytes, got {_type_name(v)}")
    if spec.array is not None and spec.array >= 0 and len(raw) != spec.array:
        raise MessageError(f"{path}: expected {spec.array} bytes, got {len(raw)}")
    return raw


def _decode_field(spec: FieldSpec, v: Any, path: str) -> Any:
    if spec.array is None:
        if spec.msg is not None:
            return _decode(spec.msg, v, path)
        return _decode_primitive(spec.base, v, path)
    if spec.is_bytes:
        return _decode_bytes(spec, v, path)
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if not isinstance(v, list | tuple):
        raise MessageError(f"{path}: expected an array ({spec.ros_type()}), got {_type_name(v)}")
    if spec.array >= 0 and len(v) != spec.array:
        raise MessageError(f"{path}: expected {spec.array} elements, got {len(v)}")
    if spec.msg is not None:
        return [_decode(spec.msg, x, f"{path}[{i}]") for i, x in enumerate(v)]
    base = spec.base
    if base in FLOAT_TYPES and all(type(x) is float for x in v):
        return list(v)
    return [_decode_primitive(base, x, f"{path}[{i}]") for i, x in enumerate(v)]


Where = str | tuple
"""A field path as decoding goes: the message's path (str), or (parent, key) for a
field and (parent, index) for an array element, spelled out only for an error."""


def _where(path: Where) -> str:
    """`path` as the text of an error: `PlanTask.ee_goal.position.x`, `obstacles[2]`."""
    if isinstance(path, str):
        return path
    parent, key = path
    return _where(parent) + (f"[{key}]" if isinstance(key, int) else f".{key}")


def _field_decoder(spec: FieldSpec) -> Callable[[Any, Where], Any]:
    """Decode one field's JSON value at `path`: the common well-typed values in a test
    or two, anything else (conversions, errors) through `_decode_field`."""

    def general(v: Any, path: Where) -> Any:
        return _decode_field(spec, v, _where(path))

    base, array, msg = spec.base, spec.array, spec.msg
    if msg is not None:
        if array is None:
            return lambda v, path: _decode(msg, v, path)

        def messages(v: Any, path: Where) -> Any:
            if type(v) is list and (array < 0 or len(v) == array):
                return [_decode(msg, x, (path, i)) for i, x in enumerate(v)]
            return general(v, path)

        return messages
    if array is not None:
        if base not in FLOAT_TYPES and base != "string":
            return general
        kind = str if base == "string" else float

        def items(v: Any, path: Where) -> Any:
            if type(v) is list and (array < 0 or len(v) == array):
                if all(type(x) is kind for x in v):
                    return v[:]
            return general(v, path)

        return items
    if base in FLOAT_TYPES:
        return lambda v, path: v if type(v) is float else general(v, path)
    if base == "string":
        return lambda v, path: v if type(v) is str else general(v, path)
    if base == "bool":
        return lambda v, path: v if type(v) is bool else general(v, path)
    lo, hi = INT_RANGES[base]
    return lambda v, path: v if type(v) is int and lo <= v <= hi else general(v, path)


_DECODERS: dict[type, dict[str, tuple[str, Callable[[Any, Where], Any]]]] = {}


def _decoders(cls: type[Message]) -> dict[str, tuple[str, Callable[[Any, Where], Any]]]:
    """JSON key (either dialect's spelling) -> (field name, its decoder), made once per
    message class."""
    out = _DECODERS.get(cls)
    if out is None:
        out = {}
        for spec in cls.__fields_spec__:
            out[spec.name] = (spec.name, _field_decoder(spec))
        for key, name in cls.__aliases__.items():
            out[key] = out[name]
        _DECODERS[cls] = out
    return out


def _decode(cls: type[Message], data: Any, path: Where) -> Any:
    if isinstance(data, cls):
        return data
    if type(data) is not dict:
        if cls.__ros1__.primitive == "time" and isinstance(data, str) and data == "now":
            ns = now_ns()
            return cls(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        if not isinstance(data, Mapping):
            raise MessageError(
                f"{_where(path)}: expected an object ({cls.__ros_type__}), got {_type_name(data)}"
            )
    kwargs: dict[str, Any] = {}
    fields = _DECODERS.get(cls) or _decoders(cls)
    for key, value in data.items():
        found = fields.get(key) if isinstance(key, str) else None
        if found is None:
            if key in cls.__ros1__.extra:
                continue
            raise MessageError(f"{_where(path)}: {cls.__ros_type__} has no field {key!r}")
        name, decode = found
        kwargs[name] = decode(value, (path, key))
    return cls(**kwargs)


# ---------------------------------------------------------------- definitions


def dependencies(cls: type[Message]) -> list[type[Message]]:
    """`cls` and every message type it contains, depth first, each once."""
    seen: dict[str, type[Message]] = {}

    def walk(c: type[Message]) -> None:
        if c.__ros_type__ in seen:
            return
        seen[c.__ros_type__] = c
        for s in c.__fields_spec__:
            if s.msg is not None:
                walk(s.msg)

    walk(cls)
    return list(seen.values())


def definition(cls: type[Message], dialect: Dialect = "ros2") -> str:
    """The `.msg` text of one type (constants, then fields) in the given dialect."""
    lines = [f"{t} {n}={v}" for n, t, v in cls.__constants__]
    r1 = cls.__ros1__
    if dialect == "ros1":
        lines += [f"{t} {k}" for k, (t, _) in r1.extra.items()]
    for s in cls.__fields_spec__:
        if dialect == "ros1":
            if s.name in r1.drop:
                continue
            lines.append(f"{s.ros_type('ros1')} {r1.rename.get(s.name, s.name)}")
        else:
            lines.append(f"{s.ros_type()} {s.name}")
    return "\n".join(lines) + "\n"


def full_definition(cls: type[Message], dialect: Dialect = "ros2") -> str:
    """The definition with its dependencies appended, as ROS tools (gendeps, MCAP,
    Foxglove) expect: each dependency after a line of 80 `=` and `MSG: pkg/Name`."""
    parts = [definition(cls, dialect)]
    for dep in dependencies(cls)[1:]:
        if dialect == "ros1" and dep.__ros1__.primitive:
            continue
        parts.append(
            "=" * 80 + f"\nMSG: {ros1_name(dep.__ros_type__)}\n" + definition(dep, dialect)
        )
    return "\n".join(parts)


def type_for_value(msg: Any) -> str | None:
    """The canonical type name of a message instance, or None for plain dicts."""
    return getattr(type(msg), "__ros_type__", None)
