"""Arm motion planning, the MoveIt role: planners, smoothing, timing (layer 3).

Every planner is a class in its own module with `solve(problem, checker)`; `PLANNERS`
maps the names a request may use to them. `planner_class` also accepts OMPL/MoveIt
spellings such as "RRTConnect" or "RRTConnectkConfigDefault".
"""

from __future__ import annotations

import re

from robotrial.planning.base import Checker, Planner, PlanResult, Problem
from robotrial.planning.est import EST, BiEST
from robotrial.planning.prm import PRM, PRMStar
from robotrial.planning.rrt import RRT
from robotrial.planning.rrt_connect import RRTConnect
from robotrial.planning.rrt_star import RRTStar
from robotrial.planning.sbl import SBL

PLANNERS: dict[str, type[Planner]] = {
    "rrt_connect": RRTConnect,
    "rrt": RRT,
    "rrt_star": RRTStar,
    "prm": PRM,
    "prm_star": PRMStar,
    "sbl": SBL,
    "est": EST,
    "biest": BiEST,
}
DEFAULT_PLANNER = "rrt_connect"


def planner_class(name: str) -> type[Planner]:
    """The planner called `name` ("" = the default), in our or OMPL's spelling."""
    if not name:
        return PLANNERS[DEFAULT_PLANNER]
    key = re.sub(r"kconfigdefault$", "", name.strip().lower())
    key = key.replace("*", "star").replace("-", "_")
    compact = {k.replace("_", ""): k for k in PLANNERS}
    key = compact.get(key.replace("_", ""), key)
    if key not in PLANNERS:
        shown = name if len(name) <= 40 else name[:40] + "..."
        raise ValueError(f"unknown planner {shown!r}; choose one of {', '.join(PLANNERS)}")
    return PLANNERS[key]


__all__ = [
    "DEFAULT_PLANNER",
    "PLANNERS",
    "Checker",
    "PlanResult",
    "Planner",
    "Problem",
    "planner_class",
]
