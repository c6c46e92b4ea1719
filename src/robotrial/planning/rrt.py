"""RRT (LaValle 1998): one tree from the start, grown toward random samples (and toward
a goal with probability `goal_bias`) until it reaches a goal. Layer 3."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from robotrial.planning.base import Checker, Planner, Problem, Tree, sample, steer


class RRT(Planner):
    name = "rrt"

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        step = self.step_size(checker)
        tree = Tree(problem.start)
        goals = problem.goals
        it = 0
        while time.perf_counter() < deadline:
            it += 1
            if rng.random() < self.goal_bias:
                target = goals[rng.integers(len(goals))]
            else:
                target = sample(rng, checker)
            near = tree.nearest(target)
            q_new = steer(tree.q[near], target, step)
            if not checker.motions_valid(tree.q[near][None], q_new[None])[0]:
                continue
            new = tree.add(q_new, near)
            dist = np.linalg.norm(goals - q_new, axis=1)
            g = int(np.argmin(dist))
            if dist[g] <= step and checker.motions_valid(q_new[None], goals[g][None])[0]:
                return np.vstack([tree.branch(new), goals[g]]), {"iterations": it, "nodes": tree.n}
        return None, {"iterations": it, "nodes": tree.n}
