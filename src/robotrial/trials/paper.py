"""Both papers' experiments as one sweep, and the report that sets them beside the
papers' own figures (layer 5).

The platform paper: SLAM in rooms A, B, C (GMapping and Hector: room dimensions, ATE),
navigation Table 1 (success and time to the goal at 0.3 m/s, and at 1.0 m/s), planning
Table 2 (RRT, RRTConnect, RRT* on the Manipulator-H class arm). g2rViewer: the desk task
with and without obstacle C, its hand path under MuJoCo's physics against the plan
(Figs. 12 and 13). `quick` runs fewer seeds and shorter drives.
"""

from __future__ import annotations

import html
from collections import defaultdict
from typing import Any

import numpy as np

from robotrial.trials.kinds import trial_kind
from robotrial.trials.report import figure_of, html_report
from robotrial.trials.store import RunRecord, RunSpec, TrialStore

# The platform paper, Table 1 (move_base + AMCL at 0.3 m/s, 10 runs per room).
PAPER_NAV = {
    "room_a": (10, 22.63),
    "room_b": (7, 27.42),
    "room_c": (6, 88.19),
}
# The platform paper, Table 2 (MoveIt + OMPL on the Manipulator-H, mean seconds).
PAPER_PLAN = {"rrt": 0.449, "rrt_connect": 0.051, "rrt_star": 5.016}
# The platform paper, Fig. 6: whether each method's map matched the room.
PAPER_SLAM = {
    ("room_a", "gmapping"): "matches",
    ("room_a", "hector"): "wrong (large empty room)",
    ("room_b", "gmapping"): "matches",
    ("room_b", "hector"): "matches",
    ("room_c", "gmapping"): "matches",
    ("room_c", "hector"): "wrong",
}
ROOMS = ("room_a", "room_b", "room_c")
# The settings each paper table lists its rows by.
GROUPED_BY = {
    "slam": ("world", "method"),
    "nav": ("world", "speed"),
    "plan": ("planner",),
    "g2r": ("obstacle",),
}


def paper_specs(quick: bool = False, seed: int = 0) -> list[RunSpec]:
    """Every run of both papers' experiments."""
    nav_runs, plan_runs, g2r_runs = (2, 5, 2) if quick else (10, 20, 10)
    duration = 60.0 if quick else 120.0
    specs: list[RunSpec] = []

    def add(kind: str, config: dict[str, Any], runs: int) -> None:
        full = trial_kind(kind).config(config)
        specs.extend(RunSpec(kind, full, s) for s in range(seed, seed + runs))

    for room in ROOMS:
        for method in ("gmapping", "hector"):
            add("slam", {"world": room, "method": method, "duration": duration}, 1)
        for speed in (0.3, 1.0):
            # the paper's move_base: navfn (Dijkstra) and the DWA
            add("nav", {"world": room, "speed": speed, "planner": "dijkstra"}, nav_runs)
    for planner in PAPER_PLAN:
        limit = 1.0 if planner == "rrt_star" else 5.0
        config = {"robot": "manipulator_h", "scene": "obstacle", "planner": planner}
        add("plan", {**config, "time_limit": limit}, plan_runs)
    for obstacle in (True, False):
        add("g2r", {"obstacle": obstacle}, g2r_runs)
    return specs


def _mean(values: list[float]) -> str:
    return f"{np.mean(values):.3g}" if values else "-"


def _table(title: str, head: list[str], rows: list[list[Any]], note: str = "") -> str:
    cells = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows
    )
    tail = f"<p>{html.escape(note)}</p>" if note else ""
    return f"<h2>{html.escape(title)}</h2><table><tr>{cells}</tr>{body}</table>{tail}"


def paper_tables(records: list[RunRecord]) -> str:
    """The papers' tables with the measured figures beside them, as HTML."""
    by: dict[tuple, list[RunRecord]] = defaultdict(list)
    for r in records:
        names = GROUPED_BY.get(r.spec.kind, ())
        by[(r.spec.kind, *(r.spec.config[n] for n in names))].append(r)
    out = []
    rows = []
    for (room, method), paper in PAPER_SLAM.items():
        runs = by.get(("slam", room, method), [])
        err = [v for v in (figure_of(r, "room.error") for r in runs) if v is not None]
        ate = [v for v in (figure_of(r, "ate.rmse") for r in runs) if v is not None]
        cm = [100 * e for e in err]
        rows.append([room, method, paper, _mean(cm), _mean([100 * a for a in ate]), len(runs)])
    out.append(
        _table(
            "SLAM in rooms A, B, C (platform paper, Fig. 6)",
            ["room", "method", "paper", "room size error (cm)", "ATE RMSE (cm)", "runs"],
            rows,
            "The paper judges each map by eye; here the room's width and depth are measured "
            "on the map and compared with the true 7.78 x 7.62 m.",
        )
    )
    rows = []
    for room, (ok, t) in PAPER_NAV.items():
        for speed in (0.3, 1.0):
            runs = by.get(("nav", room, speed), [])
            times = [r.figures.get("time") for r in runs if r.success]
            paper = f"{ok}/10, {t} s" if speed == 0.3 else "-"
            done = sum(bool(r.success) for r in runs)
            rows.append([room, speed, paper, f"{done}/{len(runs)}", _mean(times)])
    out.append(
        _table(
            "Navigation, Table 1 (success and mean time of the successes)",
            ["room", "speed (m/s)", "paper (move_base + AMCL)", "success", "mean time (s)"],
            rows,
        )
    )
    rows = []
    for planner, paper in PAPER_PLAN.items():
        runs = by.get(("plan", planner), [])
        times = [r.figures.get("planning_time") for r in runs if r.success]
        done = sum(bool(r.success) for r in runs)
        rows.append([planner, paper, _mean(times), f"{done}/{len(runs)}"])
    out.append(
        _table(
            "Arm planning, Table 2 (Manipulator-H class arm, seconds)",
            ["planner", "paper (MoveIt + OMPL)", "measured mean", "solved"],
            rows,
            "RRT* plans until its time limit in both (the paper's 5 s, 1 s here).",
        )
    )
    rows = []
    for obstacle in (True, False):
        runs = by.get(("g2r", obstacle), [])
        dev = [figure_of(r, "ee_deviation") for r in runs if r.success]
        final = [figure_of(r, "ee_final_error") for r in runs if r.success]
        done = sum(bool(r.success) for r in runs)
        rows.append(
            [
                "with obstacle C" if obstacle else "desk clear",
                f"{done}/{len(runs)}",
                _mean([100 * d for d in dev if d is not None]),
                _mean([100 * f for f in final if f is not None]),
            ]
        )
    out.append(
        _table(
            "g2rViewer desk task (Figs. 12, 13): hand path under MuJoCo against the plan",
            ["scene", "reached", "largest deviation (cm)", "final error (cm)"],
            rows,
            "Server-side physics (MuJoCo in Python). The browser-side run (mujoco-js in the "
            "page) is measured by the browser tests, not in this report.",
        )
    )
    return "\n".join(out)


def paper_report(store: TrialStore) -> str:
    """The whole page: the papers' tables first, then every run's tables and plots."""
    page = html_report(store, "robotrial: both papers' experiments")
    return page.replace("</h1>", "</h1>\n" + paper_tables(list(store.records())), 1)
