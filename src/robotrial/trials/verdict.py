"""Will this robot fit in my home? The base part of a buyer's verdict (layer 5).

For each room of a world (its `rooms` rectangles), Hybrid-A* with the robot's real
rectangular footprint plans from the dock (the `default` spawn) to the room's most open
spot: the room is reachable when a plan exists. Along the plan, the narrowest clearance
the base passes (twice the distance from its centre line to the nearest obstacle) is the
passage that room asks for, judged against the footprint: green when the base could also
turn on the spot there (wider than its turning circle), amber when it passes but cannot
turn, red when no plan gets there. Output: figures as a dict (JSON), a floor-plan picture
with the routes in their colours, and one printable HTML page.
"""

from __future__ import annotations

import base64
import html
import io
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from robotrial.model.gridmap import world_map
from robotrial.model.world import World
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.hybrid import HybridAStar
from robotrial.nav.planners import NoPath, StartBlocked


@dataclass
class RoomVerdict:
    """One room: reachable from the dock, the narrowest passage on the way (m), the
    colour (green, amber, red), the route's length (m) and the planner's time (ms)."""

    room: str
    reachable: bool
    colour: str
    passage: float | None
    route_length: float | None
    plan_ms: float
    reason: str = ""
    route: np.ndarray | None = field(default=None, repr=False)  # (N, 2) points


@dataclass
class BaseVerdict:
    world: str
    robot: str
    footprint: tuple[float, float]
    turning_diameter: float
    dock: tuple[float, float, float]
    rooms: list[RoomVerdict]
    seconds: float

    @property
    def summary(self) -> str:
        fits = sum(r.reachable for r in self.rooms)
        amber = [r.room for r in self.rooms if r.colour == "amber"]
        red = [r.room for r in self.rooms if r.colour == "red"]
        out = f"fits: {fits} of {len(self.rooms)} rooms"
        if red:
            out += f"; cannot reach {', '.join(red)}"
        if amber:
            out += f"; tight (cannot turn on the way): {', '.join(amber)}"
        return out

    def to_dict(self) -> dict[str, Any]:
        out = {**asdict(self), "summary": self.summary}
        for room in out["rooms"]:
            room.pop("route")
        return out


def _open_spot(
    clearance: np.ndarray, origin: np.ndarray, res: float, bounds
) -> tuple[float, float]:
    """The point of a room rectangle farthest from every obstacle."""
    (x0, y0), (x1, y1) = bounds
    c0, r0 = int(np.floor((x0 - origin[0]) / res)), int(np.floor((y0 - origin[1]) / res))
    c1, r1 = int(np.ceil((x1 - origin[0]) / res)), int(np.ceil((y1 - origin[1]) / res))
    rows, cols = clearance.shape
    c0, c1 = max(c0, 0), min(c1, cols)
    r0, r1 = max(r0, 0), min(r1, rows)
    window = clearance[r0:r1, c0:c1]
    if window.size == 0:
        raise ValueError(f"room {bounds} lies outside the map")
    r, c = np.unravel_index(int(np.argmax(window)), window.shape)
    return origin[0] + (c0 + c + 0.5) * res, origin[1] + (r0 + r + 0.5) * res


def check_base(world: World, footprint: Footprint, robot: str = "") -> BaseVerdict:
    """Reachability of every room from the dock for `footprint` (see the module doc)."""
    t0 = time.perf_counter()
    if not world.rooms:
        raise ValueError(f"world {world.name!r} names no rooms: give `rooms` in its YAML")
    grid = world_map(world)
    origin, res = np.asarray(grid.origin, dtype=float), grid.resolution
    clearance = ndimage.distance_transform_edt(~grid.occupied) * res
    costmap = Costmap(grid.occupied, tuple(origin), res, footprint)
    dock_pose = world.spawn("default")
    dock = (float(dock_pose.xyz[0]), float(dock_pose.xyz[1]), float(dock_pose.yaw))
    turning = float(np.hypot(footprint.length, footprint.width))
    planner = HybridAStar()
    rooms = []
    for room in world.rooms:
        goal = _open_spot(clearance, origin, res, room.bounds)
        t = time.perf_counter()
        try:
            route = planner.plan(costmap, dock, goal)  # points about a cell apart
        except (NoPath, StartBlocked) as exc:
            ms = 1e3 * (time.perf_counter() - t)
            rooms.append(RoomVerdict(room.name, False, "red", None, None, ms, str(exc)))
            continue
        ms = 1e3 * (time.perf_counter() - t)
        cells = np.floor((route - origin) / res).astype(int)
        rows, cols = clearance.shape
        cells[:, 0] = np.clip(cells[:, 0], 0, cols - 1)
        cells[:, 1] = np.clip(cells[:, 1], 0, rows - 1)
        passage = float(2 * clearance[cells[:, 1], cells[:, 0]].min())
        length = float(np.sum(np.linalg.norm(np.diff(route, axis=0), axis=1)))
        colour = "green" if passage >= turning else "amber"
        rooms.append(RoomVerdict(room.name, True, colour, passage, length, ms, route=route))
    return BaseVerdict(
        world.name,
        robot,
        (footprint.length, footprint.width),
        turning,
        dock,
        rooms,
        time.perf_counter() - t0,
    )


COLOURS = {"green": "#2e9d3a", "amber": "#e69b00", "red": "#d62728"}


def plot(verdict: BaseVerdict, world: World, png: Path | None = None) -> bytes:
    """The floor plan with each room's route in its colour; PNG bytes (also written to
    `png` when given)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    grid = world_map(world)
    rows, cols = grid.occupied.shape
    ox, oy = grid.origin[0], grid.origin[1]
    extent = (ox, ox + cols * grid.resolution, oy, oy + rows * grid.resolution)
    fig, ax = plt.subplots(figsize=(8, 6.5))
    ax.imshow(grid.occupied, origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=1.5)
    by_name = {r.room: r for r in verdict.rooms}
    for room in world.rooms:
        (x0, y0), (x1, y1) = room.bounds
        v = by_name[room.name]
        ax.add_patch(
            Rectangle(
                (x0, y0), x1 - x0, y1 - y0, fill=True, alpha=0.12, color=COLOURS[v.colour], lw=0
            )
        )
        ax.text((x0 + x1) / 2, (y0 + y1) / 2, room.name, ha="center", va="center", fontsize=9)
        if v.route is not None:
            ax.plot(v.route[:, 0], v.route[:, 1], color=COLOURS[v.colour], lw=2)
    ax.plot(*verdict.dock[:2], marker="s", color="k", ms=8, label="dock")
    ax.set_title(f"{verdict.robot or 'robot'} in {verdict.world}: {verdict.summary}", fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    data = buf.getvalue()
    if png is not None:
        png.parent.mkdir(parents=True, exist_ok=True)
        png.write_bytes(data)
    return data


def to_html(verdict: BaseVerdict, picture: bytes) -> str:
    """One printable page: the summary, a table per room, the floor plan."""
    rows = "".join(
        f"<tr><td>{html.escape(r.room)}</td>"
        f"<td style='color:{COLOURS[r.colour]}'>{r.colour}</td>"
        f"<td>{'yes' if r.reachable else 'no'}</td>"
        f"<td>{'' if r.passage is None else f'{r.passage:.2f}'}</td>"
        f"<td>{'' if r.route_length is None else f'{r.route_length:.1f}'}</td>"
        f"<td>{html.escape(r.reason)}</td></tr>"
        for r in verdict.rooms
    )
    img = base64.b64encode(picture).decode()
    length, width = verdict.footprint
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>Will the {html.escape(verdict.robot)} fit?</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto}}
td,th{{padding:.2em .8em;text-align:left}}</style></head><body>
<h1>{html.escape(verdict.summary)}</h1>
<p>{html.escape(verdict.robot)} ({length:.2f} x {width:.2f} m; turning on the spot needs
{verdict.turning_diameter:.2f} m) in {html.escape(verdict.world)}, from the dock.
Green: reachable, room to turn on the way; amber: reachable, but a passage is narrower
than the turning circle; red: no motion of the footprint gets there.</p>
<table><tr><th>room</th><th>verdict</th><th>reachable</th><th>narrowest passage (m)</th>
<th>route (m)</th><th>why not</th></tr>{rows}</table>
<p><img alt="floor plan" style="max-width:100%" src="data:image/png;base64,{img}"></p>
</body></html>
"""
