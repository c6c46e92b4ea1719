"""Checks on the `home` section of a world: the floor plan a household drew in the
page's home editor (rooms as closed outlines, doorways on their walls, furniture and
objects), kept next to the walls and bodies built from it (docs/worlds.md, "Homes").

Layer 1: plain geometry on the parsed YAML. The world loader calls `check_home` so a
home sent to the server, or run headless, is refused with the item named when its
doorway is off every wall, narrower than the wall is thick, or its furniture overlaps.
"""

from __future__ import annotations

import math
from typing import Any

from robotrial.model.checked import floats, number
from robotrial.model.robot import ModelError

DOOR_TOLERANCE = 0.01
"""How far (m) beyond half the wall thickness a doorway's centre may sit from a wall."""
MAX_HOME_ITEMS = {"rooms": 50, "doorways": 100, "furniture": 300}
"""The most entries of each list of a home (docs/worlds.md, "Limits")."""
MAX_CORNERS = 64
"""The most corners of one room."""


def _point(value: Any, what: str) -> tuple[float, float]:
    x, y = floats(value, 2, what)
    return x, y


def _number(value: Any, what: str) -> float:
    return number(value, what, above=0)


def _home_list(home: dict, group: str) -> list[dict]:
    """The list `group` of a home, each entry a mapping, at most MAX_HOME_ITEMS long."""
    items = home.get(group) or []
    if not isinstance(items, list):
        raise ModelError(f"home.{group}: expected a list, got {type(items).__name__}")
    if len(items) > MAX_HOME_ITEMS[group]:
        raise ModelError(
            f"home.{group}: {len(items)} entries; a home holds at most {MAX_HOME_ITEMS[group]}"
        )
    for i, item in enumerate(items):
        if not isinstance(item, dict):
            raise ModelError(f"home.{group}[{i}]: expected a mapping, got {type(item).__name__}")
    return items


def _label(items: Any, i: int, group: str) -> str:
    name = items[i].get("name") if isinstance(items[i], dict) else None
    return f"home.{group}[{i}]" + (f" ({name})" if name else "")


def _cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _segments_cross(
    a: tuple[float, float], b: tuple[float, float], c: tuple[float, float], d: tuple[float, float]
) -> bool:
    """True when segments ab and cd cross at a point inside both."""
    d1, d2 = _cross(c, d, a), _cross(c, d, b)
    d3, d4 = _cross(a, b, c), _cross(a, b, d)
    return d1 * d2 < 0 and d3 * d4 < 0


def _distance_to_segment(
    p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]
) -> float:
    ax, ay = b[0] - a[0], b[1] - a[1]
    length2 = ax * ax + ay * ay
    t = (
        0.0
        if length2 == 0
        else max(0.0, min(1.0, ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / length2))
    )
    return math.hypot(p[0] - a[0] - t * ax, p[1] - a[1] - t * ay)


def room_edges(home: dict) -> list[tuple[str, tuple[float, float], tuple[float, float]]]:
    """Every wall edge of every room: (label, start, end)."""
    edges = []
    for i, room in enumerate(home.get("rooms") or []):
        corners = [_point(c, f"home.rooms[{i}].corners") for c in room.get("corners", [])]
        label = _label(home["rooms"], i, "rooms")
        for k, start in enumerate(corners):
            edges.append((f"{label} edge {k + 1}", start, corners[(k + 1) % len(corners)]))
    return edges


def _footprint(item: dict, what: str) -> tuple[str, tuple[float, float], tuple[float, float]]:
    """('box', centre, (width, depth)) or ('cylinder', centre, (diameter, diameter))."""
    centre = _point(item.get("at"), f"{what}.at")
    shape = item.get("shape", "box")
    if shape not in ("box", "cylinder"):
        raise ModelError(f"{what}.shape: expected box or cylinder, got {shape!r}")
    size = item.get("size")
    if not isinstance(size, list | tuple) or len(size) != 2:
        raise ModelError(f"{what}.size: expected [width, depth] in metres, got {size!r}")
    w = _number(size[0], f"{what}.size[0]")
    d = _number(size[1], f"{what}.size[1]")
    _number(item.get("height"), f"{what}.height")
    return shape, centre, (w, d)


def _overlap(a: tuple, b: tuple) -> bool:
    """Whether two footprints overlap by more than 1 mm (touching is allowed)."""
    (sa, ca, za), (sb, cb, zb) = a, b
    eps = 1e-3
    if sa == "cylinder" and sb == "cylinder":
        return math.hypot(ca[0] - cb[0], ca[1] - cb[1]) < (za[0] + zb[0]) / 2 - eps
    if sa == "cylinder" or sb == "cylinder":
        (circle, box) = (a, b) if sa == "cylinder" else (b, a)
        r = circle[2][0] / 2
        hx, hy = box[2][0] / 2, box[2][1] / 2
        dx = max(abs(circle[1][0] - box[1][0]) - hx, 0.0)
        dy = max(abs(circle[1][1] - box[1][1]) - hy, 0.0)
        return math.hypot(dx, dy) < r - eps
    return (
        abs(ca[0] - cb[0]) < (za[0] + zb[0]) / 2 - eps
        and abs(ca[1] - cb[1]) < (za[1] + zb[1]) / 2 - eps
    )


def check_home(home: Any) -> None:
    """Refuse a home whose rooms are not closed outlines, whose doorway does not sit on a
    wall or does not fit it, or whose furniture overlaps; the message names the item."""
    if not isinstance(home, dict):
        raise ModelError(f"home: expected a mapping with rooms, got {home!r}")
    thickness = _number(home.get("thickness", 0.1), "home.thickness")
    rooms = _home_list(home, "rooms")
    if not rooms:
        raise ModelError("home.rooms: a home needs at least one room")
    for i, room in enumerate(rooms):
        label = _label(rooms, i, "rooms")
        corners = room.get("corners")
        if not isinstance(corners, list) or len(corners) < 3:
            raise ModelError(f"{label}: not closed; a room needs at least 3 corners")
        if len(corners) > MAX_CORNERS:
            raise ModelError(f"{label}: {len(corners)} corners; a room has at most {MAX_CORNERS}")
        pts = [_point(c, f"{label}.corners[{k}]") for k, c in enumerate(corners)]
        n = len(pts)
        for k in range(n):
            if pts[k] == pts[(k + 1) % n]:
                raise ModelError(f"{label}: edge {k + 1} has zero length")
        for k in range(n):
            for m in range(k + 2, n):
                if k == 0 and m == n - 1:
                    continue
                if _segments_cross(pts[k], pts[(k + 1) % n], pts[m], pts[(m + 1) % n]):
                    raise ModelError(f"{label}: edges {k + 1} and {m + 1} cross")
    edges = room_edges(home)
    doorways = _home_list(home, "doorways")
    for i, door in enumerate(doorways):
        label = _label(doorways, i, "doorways")
        at = _point(door.get("at"), f"{label}.at")
        width = _number(door.get("width"), f"{label}.width")
        gap, edge, a, b = min(
            ((_distance_to_segment(at, a, b), name, a, b) for name, a, b in edges),
            key=lambda e: e[0],
        )
        if gap > thickness / 2 + DOOR_TOLERANCE:
            raise ModelError(
                f"{label}: does not sit on a wall; the nearest wall ({edge}) is {gap:.2f} m away"
            )
        if width < thickness:
            raise ModelError(
                f"{label}: {width:.2f} m wide is narrower than the wall is thick "
                f"({thickness:.2f} m)"
            )
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        if width > length:
            raise ModelError(
                f"{label}: {width:.2f} m wide is wider than its wall ({edge}, {length:.2f} m)"
            )
    furniture = _home_list(home, "furniture")
    prints = [_footprint(f, _label(furniture, i, "furniture")) for i, f in enumerate(furniture)]
    for i in range(len(prints)):
        for j in range(i):
            if _overlap(prints[i], prints[j]):
                first, second = _label(furniture, i, "furniture"), _label(furniture, j, "furniture")
                raise ModelError(f"{first} overlaps {second}")
