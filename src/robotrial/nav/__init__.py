"""Navigation (layer 3): costmaps, global planners, local controllers, AMCL and the
navigator, as plain classes over arrays.

The default stack lives here, in one place: every navigation that does not name its
planner reads `DEFAULT_PLANNER` (and `default_controller`), so that `robotrial nav`,
`robotrial bench nav`, the carry trial and the chores it runs, the verdict's drives and
the live server drive alike. Importing this package is cheap (no numba, no numpy).
"""

DEFAULT_PLANNER = "hybrid"
"""The global planner of every navigation stack that does not name one: `robotrial nav`,
`robotrial bench nav`, the carry trial and so the verdict's chores, the verdict's drives
and the live server all read it here. Hybrid-A* with the speed profile is the best
measured (docs/benchmarks/nav.md); Dijkstra with the DWA (the platform paper's
move_base) stays selectable."""
OLD_DEFAULT_PLANNER = "dijkstra"
"""The default before: what `robotrial bench nav` measures beside the default."""


def default_controller(planner: str = DEFAULT_PLANNER) -> str:
    """The local controller a global planner gets unless one is named: the speed profile
    for Hybrid-A*'s footprint plans, the DWA for the others."""
    return "profile" if planner == "hybrid" else "dwa"
