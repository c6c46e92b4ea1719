"""What every planner shares: the checker interface, the problem, the result, a tree.

Layer 3. A planner sees a joint space (bounds, distance, straight-line interpolation)
and a validity checker with batched calls, as in OMPL; it knows nothing of robots. The
sphere model in `robotrial.collision` is one such checker, MuJoCo another.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np


class Checker(Protocol):
    """State and motion validity over a box-bounded joint space."""

    @property
    def d(self) -> int: ...

    @property
    def lower(self) -> np.ndarray: ...

    @property
    def upper(self) -> np.ndarray: ...

    def valid(self, qs: np.ndarray) -> np.ndarray:
        """(N,) bool for (N, d) configurations."""
        ...

    def motions_valid(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N,) bool: straight segments a[i] -> b[i] free (a[i] assumed free)."""
        ...


@runtime_checkable
class CompiledChecker(Checker, Protocol):
    """A checker whose motion checks are compiled kernels: a planner whose loop is
    compiled (RRTConnect) calls `collision.kernels.motion_free` and `config_free` with
    `kernel_args()` instead of calling back into Python."""

    def kernel_args(self) -> tuple:
        """The kernels' arguments after the motion (`collision.kernels.Packed`)."""
        ...


@dataclass
class Problem:
    """Plan from `start` to any of `goals` (k, d) within `time_limit` seconds."""

    start: np.ndarray
    goals: np.ndarray
    time_limit: float = 1.0
    seed: int | None = None

    def __post_init__(self) -> None:
        self.start = np.asarray(self.start, dtype=float).reshape(-1)
        self.goals = np.atleast_2d(np.asarray(self.goals, dtype=float))
        if self.goals.shape[1] != self.start.size:
            raise ValueError(
                f"goal configurations have {self.goals.shape[1]} values, "
                f"the start {self.start.size}"
            )
        if not self.time_limit > 0:
            raise ValueError(f"time_limit must be positive, got {self.time_limit}")


@dataclass
class PlanResult:
    """A planner's answer. `status`: solved, timeout, invalid_start, invalid_goal.
    `stats`: planning_time (s), iterations, nodes, checks and planner-specific counts."""

    success: bool
    path: np.ndarray
    status: str
    stats: dict[str, Any] = field(default_factory=dict)

    @property
    def planning_time(self) -> float:
        return float(self.stats.get("planning_time", 0.0))


def path_length(path: np.ndarray) -> float:
    """Joint-space length of a path (sum of Euclidean segment lengths)."""
    p = np.asarray(path, dtype=float).tolist()
    return float(sum(map(math.dist, p[:-1], p[1:])))


class Tree:
    """A growing tree of configurations with parent links and linear-scan nearest neighbours
    (fast enough for the few thousand nodes a manipulator query needs)."""

    def __init__(self, root: np.ndarray, capacity: int = 1024) -> None:
        root = np.atleast_2d(root)
        self.d = root.shape[1]
        self.q = np.empty((max(capacity, len(root)), self.d))
        self.parent = np.full(len(self.q), -1, dtype=np.int64)
        self.cost = np.zeros(len(self.q))
        self.n = 0
        for r in root:
            self.add(r, -1)

    def add(self, q: np.ndarray, parent: int, cost: float = 0.0) -> int:
        if self.n == len(self.q):
            grow = len(self.q)
            self.q = np.vstack([self.q, np.empty((grow, self.d))])
            self.parent = np.concatenate([self.parent, np.full(grow, -1, dtype=np.int64)])
            self.cost = np.concatenate([self.cost, np.zeros(grow)])
        self.q[self.n] = q
        self.parent[self.n] = parent
        self.cost[self.n] = cost
        self.n += 1
        return self.n - 1

    def nearest(self, q: np.ndarray) -> int:
        diff = self.q[: self.n] - q
        return int(np.argmin(np.einsum("ij,ij->i", diff, diff)))

    def near(self, q: np.ndarray, radius: float) -> np.ndarray:
        diff = self.q[: self.n] - q
        return np.nonzero(np.einsum("ij,ij->i", diff, diff) <= radius * radius)[0]

    def branch(self, i: int) -> np.ndarray:
        """Configurations from the root down to node i."""
        out = []
        while i >= 0:
            out.append(self.q[i])
            i = int(self.parent[i])
        return np.array(out[::-1])


class Planner:
    """Base of the planners: holds settings, times `solve`, checks the ends.

    A subclass implements `_solve(problem, checker, rng, deadline) -> (path | None, stats)`.
    `range` is the longest edge added at once (rad); 0 means 0.2 x the space's diagonal,
    OMPL's default.
    """

    name = "planner"

    def __init__(self, range: float = 0.0, goal_bias: float = 0.05) -> None:
        self.range = float(range)
        self.goal_bias = float(goal_bias)

    def step_size(self, checker: Checker) -> float:
        return self.range if self.range > 0 else default_range(checker)

    def solve(self, problem: Problem, checker: Checker) -> PlanResult:
        t0 = time.perf_counter()
        rng = np.random.default_rng(problem.seed)
        if not checker.valid(problem.start[None])[0]:
            stats = {"planning_time": time.perf_counter() - t0}
            return PlanResult(False, problem.start[None], "invalid_start", stats)
        ok = checker.valid(problem.goals)
        if not np.any(ok):
            return PlanResult(
                False,
                problem.start[None],
                "invalid_goal",
                {"planning_time": time.perf_counter() - t0},
            )
        goals = problem.goals[ok]
        if checker.motions_valid(problem.start[None], goals[:1])[0]:
            path, stats = np.array([problem.start, goals[0]]), {"direct": True}
        else:
            sub = Problem(problem.start, goals, problem.time_limit, problem.seed)
            path, stats = self._solve(sub, checker, rng, t0 + problem.time_limit)
        stats = {"planner": self.name, **stats, "planning_time": time.perf_counter() - t0}
        if path is None:
            return PlanResult(False, problem.start[None], "timeout", stats)
        stats["path_length"] = path_length(path)
        return PlanResult(True, np.asarray(path), "solved", stats)

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        raise NotImplementedError


def default_range(checker: Checker) -> float:
    """0.2 x the joint space's diagonal: OMPL's default longest edge."""
    return 0.2 * float(np.linalg.norm(np.asarray(checker.upper) - np.asarray(checker.lower)))


def steer(a: np.ndarray, b: np.ndarray, step: float) -> np.ndarray:
    """The point `step` along a -> b, or b when it is closer."""
    diff = b - a
    dist = float(np.sqrt(diff @ diff))
    return b.copy() if dist <= step else a + diff * (step / dist)


def sample(rng: np.random.Generator, checker: Checker) -> np.ndarray:
    return rng.uniform(checker.lower, checker.upper)
