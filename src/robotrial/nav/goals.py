"""Navigation goals: drawing random ones in a map's free space, and judging a goal before
the base drives (layer 3).

`sample_goals` draws poses (x, y, yaw) where the base's rectangle keeps at least
`clearance` m from every occupied cell, uniformly over the free space inside a region
(the home's interior, or the whole map). `check_goal` says, in words, what is wrong
with a goal before anything moves: off the map, inside an obstacle, too near one for
the rectangle at that heading, already reached, or out of reach for the footprint from
the start (Hybrid-A*, the footprint planner, asked for the whole pose; from a start
where the map shows the base touching something, from where the least turn and straight
drive that gets it clear, `escape_move`, takes it, as the navigator does; and where no
forward plan gets there, a plan that may back out of a pocket too narrow to turn in).
The command line, the live server and the benchmark all ask it, so a goal is refused
the same way everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robotrial.nav.costmap import Costmap
from robotrial.nav.hybrid import YAW_BINS, HybridAStar, footprint_hits
from robotrial.nav.planners import NoPath, StartBlocked
from robotrial.nav.profile import rectangle_clearance

GOAL_CLEARANCE = 0.10
"""How far (m) the rectangle at a goal keeps from every obstacle: a sampled goal keeps
it, and a goal given nearer than half of it is refused as too near. Localization puts
the base a few cm off where it believes it is."""


ESCAPE_TURN = 0.8  # rad: the largest turn on the spot an escape from a touching pose makes
ESCAPE_RUN = 0.4  # m: the longest straight drive after it
_BIN = 2 * np.pi / YAW_BINS  # the footprint planner's yaw bins: an escape ends on one


def escape_move(
    costmap: Costmap, pose: tuple[float, float, float], margin: float, blocked: np.ndarray
) -> tuple[float, float] | None:
    """The least move that takes a base the map shows touching something (or nearer
    than `margin`, m, to a `blocked` cell) to where the footprint planner's check of the
    rectangle grown by `margin` is clear, never nearer than it stands on the way: a
    turn on the spot to a heading (rad), then a straight drive of a signed distance
    (m). None when no turn of up to ESCAPE_TURN and drive of up to ESCAPE_RUN does it.
    A base standing somewhere is not in a wall: the map drew the wall a cell thick, or
    localization puts the base a few cm off."""
    x, y, yaw = (float(v) for v in pose[:3])
    here = float(rectangle_clearance(costmap, np.array([[x, y, yaw]]), blocked)[0])
    floor = min(here, margin) - 1e-3
    k0 = int(np.round(yaw / _BIN))
    best: tuple[float, float, float] | None = None
    for k in range(k0 - int(ESCAPE_TURN / _BIN), k0 + int(ESCAPE_TURN / _BIN) + 1):
        heading = k * _BIN
        turn = float((heading - yaw + np.pi) % (2 * np.pi) - np.pi)
        spin = np.linspace(yaw, yaw + turn, max(2, int(abs(turn) / 0.01) + 2))
        sweep = np.column_stack([np.full(len(spin), x), np.full(len(spin), y), spin])
        if rectangle_clearance(costmap, sweep, blocked).min() < floor:
            continue
        c, s = np.cos(heading), np.sin(heading)
        for run in np.arange(0.0, ESCAPE_RUN + 1e-9, 0.05):
            for sign in (1.0, -1.0) if run else (1.0,):
                d = np.linspace(0.0, sign * run, max(2, int(run / 0.01) + 2))
                line = np.column_stack([x + c * d, y + s * d, np.full(len(d), heading)])
                room = rectangle_clearance(costmap, line, blocked)
                if room.min() < floor or footprint_hits(costmap, line[-1:], margin, blocked)[0]:
                    continue
                cost = 0.5 * abs(turn) + run
                if best is None or cost < best[0]:
                    best = (cost, heading, sign * run)
    return None if best is None else (best[1], best[2])


@dataclass(frozen=True)
class GoalCheck:
    """A verdict on a goal: `kind` is 'ok', 'off_map', 'in_obstacle', 'too_close',
    'here' (the base already stands on it) or 'unreachable'; `reason` says it in words
    (empty when ok); `plan` holds the footprint planner's poses (N, 3) when it was asked
    and found a way."""

    kind: str
    reason: str = ""
    plan: np.ndarray | None = None

    @property
    def ok(self) -> bool:
        return self.kind == "ok"


def _fmt(x: float, y: float) -> str:
    return f"({x:.2f}, {y:.2f})"


def check_goal(
    costmap: Costmap,
    goal: tuple[float, float, float],
    start: tuple[float, float, float] | None = None,
    planner: HybridAStar | None = None,
    xy_tolerance: float = 0.1,
    clearance: float = 0.5 * GOAL_CLEARANCE,
) -> GoalCheck:
    """Whether the base can be sent to `goal` on `costmap`: the checks of the module
    docstring, in that order; the reachability check (a Hybrid-A* plan to the whole pose)
    only when `start` is known. Never raises for a bad goal: the answer says why."""
    gx, gy, gyaw = (float(v) for v in goal)
    if not all(np.isfinite([gx, gy, gyaw])):
        return GoalCheck("off_map", "the goal must be three finite numbers: x, y and yaw")
    where = _fmt(gx, gy)
    rc = costmap.world_to_cell(np.array([gx, gy]))
    if not costmap.inside(rc):
        (x0, y0), res = costmap.origin, costmap.resolution
        rows, cols = costmap.shape
        return GoalCheck(
            "off_map",
            f"the goal {where} is off the map, which spans x {x0:.2f} .. {x0 + cols * res:.2f} "
            f"and y {y0:.2f} .. {y0 + rows * res:.2f} m",
        )
    r, c = int(rc[0]), int(rc[1])
    if costmap.static[r, c] or costmap.obstacles[r, c]:
        return GoalCheck("in_obstacle", f"the goal {where} is inside an obstacle")
    if costmap.unknown[r, c]:
        return GoalCheck("in_obstacle", f"the goal {where} lies where the map is unknown")
    room = float(rectangle_clearance(costmap, np.array([[gx, gy, gyaw]]), cap=clearance)[0])
    if room < clearance:
        fp = costmap.footprint
        near = "touches an obstacle" if room < 0 else f"keeps only {100 * room:.0f} cm from one"
        return GoalCheck(
            "too_close",
            f"the goal {where} is too near an obstacle: the {fp.length:.2f} x {fp.width:.2f} m "
            f"base facing {np.degrees(gyaw):.0f} deg there {near} (it needs "
            f"{100 * clearance:.0f} cm)",
        )
    if start is None:
        return GoalCheck("ok")
    sx, sy, syaw = (float(v) for v in start)
    dist = float(np.hypot(gx - sx, gy - sy))
    turn = abs((gyaw - syaw + np.pi) % (2 * np.pi) - np.pi)
    if dist <= xy_tolerance and turn <= 0.15:
        return GoalCheck("here", f"the base already stands on the goal ({dist:.2f} m away)")
    planner = planner or HybridAStar()
    try:
        try:
            poses = planner.plan_poses(costmap, (sx, sy, syaw), (gx, gy, gyaw))
        except StartBlocked:
            # the base stands where the map shows it touching something: the navigator
            # first gets it clear (`escape_move`), so the goal is judged from there
            blocked = planner.blocked(costmap)
            move = escape_move(costmap, (sx, sy, syaw), planner.config.margin, blocked)
            if move is None:
                return GoalCheck(
                    "unreachable",
                    f"the base at {_fmt(sx, sy)} stands where the map shows it touching "
                    f"something, and no turn on the spot of up to "
                    f"{np.degrees(ESCAPE_TURN):.0f} deg and drive of up to {ESCAPE_RUN:.1f} m "
                    "gets it clear",
                )
            heading, run = move
            clear = (sx + run * np.cos(heading), sy + run * np.sin(heading), heading)
            poses = planner.plan_poses(costmap, clear, (gx, gy, gyaw))
    except NoPath as err:
        try:
            # a base in a pocket it drove into forwards, too narrow to turn in, backs
            # out first (the navigator does, as far as a plan that may reverse says)
            back = planner.reversing()
            return GoalCheck("ok", plan=back.plan_poses(costmap, (sx, sy, syaw), (gx, gy, gyaw)))
        except NoPath:
            pass
        text = str(err)  # the planner's words name the goal already, mostly
        if not text.startswith("the goal"):
            text = f"the goal {where} is out of reach: {text}"
        return GoalCheck("unreachable", text)
    return GoalCheck("ok", plan=poses)


def free_region(costmap: Costmap, region: tuple[tuple[float, float], tuple[float, float]] | None):
    """Cells (rows, cols) inside `region` ((xmin, ymin), (xmax, ymax); None: the whole
    map) where the centre keeps the inscribed radius from occupied and unknown cells."""
    fp = costmap.footprint
    ok = (costmap.distance >= fp.inscribed_radius) & ~costmap.unknown
    if region is not None:
        (x0, y0), (x1, y1) = region
        centres = costmap.cell_to_world(np.indices(costmap.shape).transpose(1, 2, 0))
        ok &= (centres[..., 0] >= x0) & (centres[..., 0] <= x1)
        ok &= (centres[..., 1] >= y0) & (centres[..., 1] <= y1)
    return np.nonzero(ok)


def sample_goals(
    costmap: Costmap,
    count: int,
    rng: np.random.Generator,
    region: tuple[tuple[float, float], tuple[float, float]] | None = None,
    clearance: float = GOAL_CLEARANCE,
    max_draws: int = 200_000,
) -> np.ndarray:
    """`count` poses (count, 3) drawn uniformly over the free space in `region` with a
    uniform heading, each where the rectangle keeps `clearance` m from every obstacle;
    raises ValueError when the region has no such place."""
    rows, cols = free_region(costmap, region)
    if len(rows) == 0:
        raise ValueError("goal sampler: no free space where the base fits")
    out: list[np.ndarray] = []
    drawn = 0
    res = costmap.resolution
    while len(out) < count:
        n = min(4 * (count - len(out)) + 16, max_draws - drawn)
        if n <= 0:
            raise ValueError(
                f"goal sampler: only {len(out)} of {count} poses keep {clearance:.2f} m "
                f"from obstacles after {drawn} draws"
            )
        drawn += n
        k = rng.integers(0, len(rows), n)
        x = costmap.origin[0] + (cols[k] + rng.random(n)) * res
        y = costmap.origin[1] + (rows[k] + rng.random(n)) * res
        yaw = rng.uniform(-np.pi, np.pi, n)
        poses = np.column_stack([x, y, yaw])
        room = rectangle_clearance(costmap, poses, cap=clearance)
        out.extend(poses[room >= clearance])
    return np.array(out[:count])
