"""The buyer's verdict on paper: pictures, one printable HTML page, PDF or PNG (layer 5).

`pictures(verdict)` draws the floor plan (rooms in their colours, the routes from the
dock, each furniture top as a heat map of how many parked poses reach each point), the
reach maps surface by surface, and the height sweep. `to_html(verdicts)` writes one page:
the summary line on top, then a column per robot with its pictures and, below them, its
tables; with two robots a table of both comes first, the rows that differ highlighted.
`write_page(verdicts, path)` puts the summary and the floor plans on one A4 sheet, as PDF
or PNG (matplotlib writes both).
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robotrial.model.gridmap import world_map

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from robotrial.model.world import World
    from robotrial.trials.reach import ReachVerdict
    from robotrial.trials.verdict import BaseVerdict, HomeVerdict

COLOURS = {"green": "#2e9d3a", "amber": "#e69b00", "red": "#d62728"}
REACH_COLOURS = {"yes": COLOURS["green"], "partly": COLOURS["amber"], "no": COLOURS["red"]}
HEAT_MAP = "viridis"


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    _plt().close(fig)
    return buf.getvalue()


def draw_floor(ax: Axes, verdict: HomeVerdict) -> None:
    """The floor plan: rooms tinted by their colour, routes, the dock, furniture tops
    with their reach heat maps (grey: not reached)."""
    if verdict.home is None:
        raise ValueError("the verdict carries no world to draw")
    draw_rooms(ax, verdict.base, verdict.home, verdict.reach)


def draw_rooms(ax: Axes, base: BaseVerdict, home: World, reach: ReachVerdict | None) -> None:
    """The floor plan of the base part, with `reach`'s heat maps when given."""
    from matplotlib.patches import Rectangle

    grid = world_map(home)
    rows, cols = grid.occupied.shape
    ox, oy = grid.origin[0], grid.origin[1]
    extent = (ox, ox + cols * grid.resolution, oy, oy + rows * grid.resolution)
    ax.imshow(grid.occupied, origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=1.5)
    by_name = {r.room: r for r in base.rooms}
    for room in home.rooms:
        (x0, y0), (x1, y1) = room.bounds
        v = by_name[room.name]
        ax.add_patch(
            Rectangle(
                (x0, y0), x1 - x0, y1 - y0, fill=True, alpha=0.12, color=COLOURS[v.colour], lw=0
            )
        )
        ax.text((x0 + x1) / 2, y1 - 0.25, room.name, ha="center", va="top", fontsize=8)
        if v.route is not None:
            ax.plot(v.route[:, 0], v.route[:, 1], color=COLOURS[v.colour], lw=2)
    heat = _draw_heat(ax, reach.surfaces) if reach is not None else None
    if heat is not None:
        bar = ax.figure.colorbar(heat, ax=ax, shrink=0.6, pad=0.02)
        bar.set_label("parked poses that reach the point (grey: none)", fontsize=7)
        bar.ax.tick_params(labelsize=7)
    ax.plot(*base.dock[:2], marker="s", color="k", ms=7, label="dock")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=7)


def _draw_heat(ax: Axes, surfaces) -> object | None:
    """Every surface's outline and heat map as cells; returns the coloured collection
    (for a colour bar) or None when no surface has points."""
    from matplotlib.collections import PolyCollection

    top = max((int(s.heat.max()) for s in surfaces if len(s.heat)), default=1)
    mapped = None
    for s in surfaces:
        ax.plot(s.outline[:, 0], s.outline[:, 1], color="k", lw=0.6)
        if not len(s.points):
            continue
        hit = s.heat > 0
        cells = s.squares()
        ax.add_collection(PolyCollection(cells[~hit], facecolors="#c8c8c8", linewidths=0))
        mapped = PolyCollection(
            cells[hit], array=s.heat[hit], cmap=HEAT_MAP, clim=(1, max(top, 2)), linewidths=0
        )
        ax.add_collection(mapped)
    return mapped


def plot(verdict: BaseVerdict, world: World, png: Path | None = None) -> bytes:
    """The base part's floor plan alone (rooms, routes, the dock) as PNG bytes, also
    written to `png` when given."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 6.5))
    draw_rooms(ax, verdict, world, None)
    ax.set_title(f"{verdict.robot or 'robot'} in {verdict.world}: {verdict.summary}", fontsize=9)
    data = _png(fig)
    if png is not None:
        png.parent.mkdir(parents=True, exist_ok=True)
        png.write_bytes(data)
    return data


def draw_heights(ax: Axes, verdict: HomeVerdict) -> None:
    """The height sweep: for each distance ahead of the base's front edge, the span of
    heights the hand reaches."""
    h = verdict.reach.heights
    if h is None:
        ax.text(0.5, 0.5, verdict.reach.reason, ha="center", va="center", transform=ax.transAxes)
        ax.set_axis_off()
        return
    for d, lo, hi in zip(h.ahead, h.lowest, h.highest, strict=True):
        if lo is not None and hi is not None:
            ax.plot([d, d], [lo, hi], color=COLOURS["green"], lw=6, solid_capstyle="butt")
            ax.text(d + 0.012, hi, f"{hi:.2f}", fontsize=7, va="center")
            ax.text(d + 0.012, lo, f"{lo:.2f}", fontsize=7, va="center")
    ax.axvline(0.0, color="k", lw=1)
    ax.set_xlim(-0.05, max(h.ahead) + 0.1)
    ax.set_ylim(0.0, 2.2)
    ax.set_xlabel("ahead of the base's front (m)")
    ax.set_ylabel("hand height (m)")
    ax.set_title("heights the hand reaches", fontsize=9)


def reach_maps(verdict: HomeVerdict) -> bytes | None:
    """Each furniture top's heat map, with the parked poses the base could use; None
    when the reach was not checked."""
    surfaces = verdict.reach.surfaces
    if not verdict.reach.checked or not surfaces:
        return None
    plt = _plt()
    n = len(surfaces)
    cols = min(4, n)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.0 * rows), squeeze=False)
    for ax, s in zip(axes.ravel(), surfaces, strict=False):
        _draw_heat(ax, [s])
        for x, y, yaw in s.park:
            ax.arrow(x, y, 0.15 * np.cos(yaw), 0.15 * np.sin(yaw), width=0.01, color="0.4")
        ax.set_aspect("equal")
        ax.tick_params(labelsize=6)
        ax.set_title(
            f"{s.surface} ({s.height:.2f} m): {100 * s.share:.0f} %",
            fontsize=8,
            color=REACH_COLOURS[s.verdict],
        )
    for ax in axes.ravel()[n:]:
        ax.set_axis_off()
    fig.suptitle(
        "what the hand reaches on each top (colour: parked poses that reach a point; "
        "grey: none; arrows: the parked poses)",
        fontsize=9,
    )
    fig.tight_layout()
    return _png(fig)


def pictures(verdict: HomeVerdict) -> dict[str, bytes]:
    """PNG pictures by name: `floor_plan`, and when the arm was checked `reach` and
    `heights`."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 6.5))
    draw_floor(ax, verdict)
    ax.set_title(f"{verdict.robot} in {verdict.world}", fontsize=9)
    out = {"floor_plan": _png(fig)}
    maps = reach_maps(verdict)
    if maps is not None:
        out["reach"] = maps
        fig, ax = plt.subplots(figsize=(4, 3.5))
        draw_heights(ax, verdict)
        out["heights"] = _png(fig)
    return out


def _cell(text: str, colour: str = "") -> str:
    style = f" style='color:{colour}'" if colour else ""
    return f"<td{style}>{html.escape(text)}</td>"


def _tables(v: HomeVerdict) -> str:
    """One robot's tables: rooms, surfaces, heights, chores."""
    length, width = v.base.footprint
    rooms = "".join(
        "<tr>"
        + _cell(r.room)
        + _cell(r.colour, COLOURS[r.colour])
        + _cell("" if r.passage is None else f"{r.passage:.2f}")
        + _cell("" if r.route_length is None else f"{r.route_length:.1f}")
        + _cell(r.reason)
        + "</tr>"
        for r in v.base.rooms
    )
    out = [
        f"<p>{html.escape(v.robot)}: {length:.2f} x {width:.2f} m; turning on the spot "
        f"needs {v.base.turning_diameter:.2f} m. Green: reachable with room to turn; "
        "amber: reachable, a passage is narrower than the turning circle; red: no motion "
        "of the footprint gets there.</p>",
        "<table><tr><th>room</th><th>verdict</th><th>narrowest passage (m)</th>"
        f"<th>route (m)</th><th>why not</th></tr>{rooms}</table>",
    ]
    if not v.reach.checked:
        out.append(f"<p><b>Reach:</b> {html.escape(v.reach.reason)}</p>")
    else:
        surfaces = "".join(
            "<tr>"
            + _cell(s.surface)
            + _cell(s.room)
            + _cell(f"{s.height:.2f}")
            + _cell(f"{100 * s.share:.0f} %", REACH_COLOURS[s.verdict])
            + _cell(str(s.parked))
            + _cell(s.reason)
            + "</tr>"
            for s in v.reach.surfaces
        )
        out.append(
            "<table><tr><th>surface</th><th>room</th><th>height (m)</th><th>reached</th>"
            f"<th>parked poses</th><th>why not</th></tr>{surfaces}</table>"
        )
        h = v.reach.heights
        span = None if h is None else h.span
        out.append(
            "<p><b>Heights:</b> "
            + (
                "none reached"
                if span is None
                else f"the hand reaches from {span[0]:.2f} m to {span[1]:.2f} m above the "
                "floor just ahead of the base"
            )
            + "</p>"
        )
    if v.chores is not None:
        chores = "".join(
            "<tr>"
            + _cell(c.name)
            + _cell(
                f"refused: {c.refused}" if c.refused else f"{c.successes} of {c.runs}",
                COLOURS["green" if c.done else "red"],
            )
            + _cell("" if c.mean_time is None else f"{c.mean_time:.0f}")
            + _cell(
                ""
                if c.shares is None
                else ", ".join(f"{what} {t:.0f}" for what, t in c.shares.items())
            )
            + _cell(", ".join(f"{p} ({n})" for p, n in c.failed_phases.items()))
            + "</tr>"
            for c in v.chores
        )
        out.append(
            "<table><tr><th>chore</th><th>succeeded</th><th>time (s, simulated)</th>"
            "<th>of which (s)</th>"
            f"<th>failed in</th></tr>{chores}</table>"
        )
    return "\n".join(out)


def _img(data: bytes, alt: str) -> str:
    return (
        f"<p><img alt='{html.escape(alt)}' style='max-width:100%' "
        f"src='data:image/png;base64,{base64.b64encode(data).decode()}'></p>"
    )


def to_html(
    verdicts: HomeVerdict | Sequence[HomeVerdict],
    images: Sequence[dict[str, bytes]] | None = None,
) -> str:
    """One printable page; `images` are the robots' `pictures` when already drawn."""
    from robotrial.trials.verdict import compare

    vs = [verdicts] if not isinstance(verdicts, Sequence) else list(verdicts)
    pics = list(images) if images is not None else [pictures(v) for v in vs]
    names = ", ".join(v.robot for v in vs)
    head = "".join(f"<h1>{html.escape(v.summary)}</h1>" for v in vs) if len(vs) == 1 else ""
    diff = ""
    if len(vs) > 1:
        table = compare(vs)
        body = "".join(
            f"<tr{' class=differ' if r['differ'] else ''}><th>{html.escape(r['item'])}</th>"
            + "".join(_cell(x) for x in r["values"])
            + "</tr>"
            for r in table["rows"]
        )
        heads = "".join(f"<th>{html.escape(v.robot)}</th>" for v in vs)
        head = f"<h1>{html.escape(names)} in {html.escape(vs[0].world)}</h1>"
        diff = (
            f"<table class=compare><tr><th></th>{heads}</tr>{body}</table>"
            "<p>Highlighted: where the robots differ.</p>"
        )
    columns = "".join(
        f"<div class=col><h2>{html.escape(v.robot)}</h2>"
        + (f"<p><b>{html.escape(v.summary)}</b></p>" if len(vs) > 1 else "")
        + "".join(
            _img(p[k], k.replace("_", " ")) for k in ("floor_plan", "heights", "reach") if k in p
        )
        + _tables(v)
        + "</div>"
        for v, p in zip(vs, pics, strict=True)
    )
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>Will the {html.escape(names)} fit?</title>
<style>body{{font-family:sans-serif;max-width:{60 * len(vs)}em;margin:2em auto}}
h1{{font-size:1.3em}} td,th{{padding:.2em .8em;text-align:left;vertical-align:top}}
.cols{{display:flex;gap:2em}} .col{{flex:1;min-width:0}}
tr.differ{{background:#fff3c4}} @media print{{.col{{break-inside:avoid}}}}</style>
</head><body>
{head}
{diff}
<div class=cols>{columns}</div>
</body></html>
"""


def write_page(verdicts: HomeVerdict | Sequence[HomeVerdict], path: Path) -> Path:
    """One sheet (A4 tall; wider for two robots), as PDF or PNG by the file's suffix: the
    summary on top, each robot's floor plan with its reach heat maps and its height sweep,
    and the figures row by row (rows where two robots differ highlighted)."""
    import textwrap

    from robotrial.trials.verdict import compare

    path = Path(path)
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in ("pdf", "png"):
        raise ValueError(f"{path}: the page is written as .pdf or .png, not {path.suffix!r}")
    vs = [verdicts] if not isinstance(verdicts, Sequence) else list(verdicts)
    plt = _plt()
    n = len(vs)
    fig = plt.figure(figsize=(8.27 * (1 if n == 1 else 1.6), 11.69))
    width = 100 if n == 1 else 165
    lines = [textwrap.fill(f"{v.robot}: {v.summary}", width) for v in vs]
    fig.text(0.04, 0.985, "\n".join(lines), va="top", ha="left", fontsize=9, weight="bold")
    grid = fig.add_gridspec(
        3, n, height_ratios=[2.1, 0.9, 1.9], top=0.9, bottom=0.02, hspace=0.3, wspace=0.25
    )
    for i, v in enumerate(vs):
        ax = fig.add_subplot(grid[0, i])
        draw_floor(ax, v)
        ax.set_title(f"{v.robot} in {v.world}", fontsize=9)
        draw_heights(fig.add_subplot(grid[1, i]), v)
    rows = [r for r in compare(vs)["rows"] if r["part"] != "summary"]
    table_ax = fig.add_subplot(grid[2, :])
    table_ax.set_axis_off()
    if rows:
        cells = [[r["part"], r["item"], *(_short(x) for x in r["values"])] for r in rows]
        table = table_ax.table(
            cellText=cells,
            colLabels=["part", "item", *(v.robot for v in vs)],
            loc="upper center",
            cellLoc="left",
        )
        table.auto_set_font_size(False)
        table.set_fontsize(7)
        table.auto_set_column_width(list(range(len(vs) + 2)))
        for i, r in enumerate(rows, start=1):
            if r["differ"] and n > 1:
                for j in range(len(vs) + 2):
                    table[i, j].set_facecolor("#fff3c4")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, format=fmt, dpi=120)
    plt.close(fig)
    return path


def _short(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."
