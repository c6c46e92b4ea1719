"""Values read from parsed YAML or JSON, checked: finite numbers, fixed-length lists of
numbers, mappings, texts. Every refusal is a ModelError that names the entry and quotes
the value short, never as a Python type name.

Layer 1: imports only `robotrial.model.robot` (ModelError). The world and home readers
use it, so that a world sent by a stranger is refused in words, never with a crash.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from robotrial.model.robot import ModelError


def shown(value: Any) -> str:
    """A value as a message quotes it: short, without Python's type names."""
    out = repr(value) if isinstance(value, str) else str(value)
    return out if len(out) <= 60 else out[:60] + "..."


def floats(value: Any, n: int, what: str) -> tuple[float, ...]:
    """`n` finite numbers given as a list."""
    if not isinstance(value, list | tuple | np.ndarray) or len(value) != n:
        raise ModelError(f"{what}: expected {n} numbers, got {shown(value)}")
    return tuple(number(v, f"{what}[{i}]") for i, v in enumerate(value))


def number(value: Any, what: str, least: float | None = None, above: float | None = None) -> float:
    """A finite number (or a string YAML left unread, such as 1e-3), at least `least` or
    above `above` when given."""
    try:
        if isinstance(value, bool) or not isinstance(value, numbers.Real | str):
            raise ValueError
        v = float(value)
    except ValueError:
        raise ModelError(f"{what}: expected a number, got {shown(value)}") from None
    if not math.isfinite(v):
        raise ModelError(f"{what}: expected a finite number, got {shown(value)}")
    if least is not None and v < least:
        raise ModelError(f"{what}: must be at least {least:g}, got {v:g}")
    if above is not None and v <= above:
        raise ModelError(f"{what}: must be more than {above:g}, got {v:g}")
    return v


def mapping(value: Any, what: str) -> dict:
    """A mapping (empty when absent)."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ModelError(f"{what}: expected a mapping, got {shown(value)}")
    return value


def text(value: Any, what: str, default: str = "") -> str:
    """A name or a text (a number is taken as its text); `default` when absent."""
    if value is None:
        return default
    if isinstance(value, dict | list):
        raise ModelError(f"{what}: expected a name or a text, got {shown(value)}")
    return str(value)
