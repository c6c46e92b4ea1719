"""The object catalogue: what the robot knows each kind of object looks like (layer 4).

A kind is a shape, its size standing upright and its colour, as a robot's object
database holds them (no pose: where an object is, the robot finds out by looking). The
detector classifies what it sees against these; the grasp is chosen from the shape.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

SHAPES = ("cylinder", "box", "sphere")


@dataclass(frozen=True)
class ObjectKind:
    """One kind of object: `shape` (cylinder, box, sphere), `size` its full extents
    (x, y, z) standing as it stands (a cylinder: diameter, diameter, height), `rgb` its
    colour (0-1)."""

    name: str
    shape: str
    size: tuple[float, float, float]
    rgb: tuple[float, float, float]

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ValueError(f"object kind {self.name!r}: shape must be one of {SHAPES}")
        if len(self.size) != 3 or min(self.size) <= 0:
            raise ValueError(f"object kind {self.name!r}: size must be three positive lengths")

    @property
    def height(self) -> float:
        return float(self.size[2])

    @property
    def width(self) -> float:
        """The larger horizontal extent (m)."""
        return float(max(self.size[0], self.size[1]))

    def looks_like(self, other: ObjectKind) -> bool:
        """Whether the camera cannot tell the two apart: the same shape, size and colour
        (two objects of a home can be alike under different names)."""
        return (self.shape, self.size, self.rgb) == (other.shape, other.size, other.rgb)

    @property
    def grip_width(self) -> float:
        """How wide the fingers must open to close across it from the side (m): the
        diameter of a round object, the shorter side of a box."""
        return float(min(self.size[0], self.size[1]))


class Catalogue:
    """The kinds the robot knows, by name."""

    def __init__(self, kinds: Iterable[ObjectKind]) -> None:
        self.kinds = tuple(kinds)
        self._by_name = {k.name: k for k in self.kinds}

    def __iter__(self):
        return iter(self.kinds)

    def __len__(self) -> int:
        return len(self.kinds)

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def kind(self, name: str) -> ObjectKind:
        if name not in self._by_name:
            known = ", ".join(self._by_name) or "nothing"
            raise KeyError(f"no object {name!r} in the robot's catalogue; it knows {known}")
        return self._by_name[name]
