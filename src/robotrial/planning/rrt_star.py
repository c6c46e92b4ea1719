"""RRT* (Karaman and Frazzoli 2011): RRT that picks the cheapest parent among near nodes
and rewires them through each new node, so the path shortens as time goes on.

Layer 3. Anytime: it uses the whole time limit (as OMPL's RRT* does in MoveIt) unless
`max_iterations` stops it first; the best path found so far is returned.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from robotrial.planning.base import Checker, Planner, Problem, Tree, sample, steer


class RRTStar(Planner):
    name = "rrt_star"

    def __init__(
        self, range: float = 0.0, goal_bias: float = 0.05, max_iterations: int = 0
    ) -> None:
        super().__init__(range, goal_bias)
        self.max_iterations = int(max_iterations)

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        step = self.step_size(checker)
        d = checker.d
        tree = Tree(problem.start)
        goals = problem.goals
        # gamma from the space's volume, as in OMPL (unit-ball volume dropped into a constant)
        vol = float(np.prod(np.asarray(checker.upper) - np.asarray(checker.lower)))
        gamma = 2.0 * (1.0 + 1.0 / d) ** (1.0 / d) * vol ** (1.0 / d)
        best_goal, best_cost, best_node = -1, math.inf, -1
        first_time = None
        it = 0
        t0 = time.perf_counter()
        while time.perf_counter() < deadline:
            if self.max_iterations and it >= self.max_iterations:
                break
            it += 1
            if rng.random() < self.goal_bias:
                target = goals[rng.integers(len(goals))]
            else:
                target = sample(rng, checker)
            near_i = tree.nearest(target)
            q_new = steer(tree.q[near_i], target, step)
            radius = min(step, gamma * (math.log(tree.n + 1) / (tree.n + 1)) ** (1.0 / d))
            near = tree.near(q_new, radius)
            if near_i not in near:
                near = np.append(near, near_i)
            dists = np.linalg.norm(tree.q[near] - q_new, axis=1)
            costs = tree.cost[near] + dists
            order = np.argsort(costs)
            parent, parent_cost = -1, math.inf
            for k in order:
                if checker.motions_valid(tree.q[near[k]][None], q_new[None])[0]:
                    parent, parent_cost = int(near[k]), float(costs[k])
                    break
            if parent < 0:
                continue
            new = tree.add(q_new, parent, parent_cost)
            # rewire: near nodes that are cheaper through the new node
            cheaper = near[parent_cost + dists < tree.cost[near] - 1e-12]
            if len(cheaper):
                ok = checker.motions_valid(np.repeat(q_new[None], len(cheaper), 0), tree.q[cheaper])
                for node in cheaper[ok]:
                    delta = (
                        parent_cost + float(np.linalg.norm(tree.q[node] - q_new)) - tree.cost[node]
                    )
                    tree.parent[node] = new
                    self._shift_costs(tree, int(node), delta)
            gd = np.linalg.norm(goals - q_new, axis=1)
            g = int(np.argmin(gd))
            if gd[g] <= step and parent_cost + gd[g] < best_cost:
                if checker.motions_valid(q_new[None], goals[g][None])[0]:
                    best_goal, best_node = g, new
                    best_cost = parent_cost + float(gd[g])
                    first_time = first_time or time.perf_counter() - t0
            if best_node >= 0:
                best_cost = tree.cost[best_node] + float(
                    np.linalg.norm(goals[best_goal] - tree.q[best_node])
                )
        stats = {"iterations": it, "nodes": tree.n, "first_solution_time": first_time}
        if best_node < 0:
            return None, stats
        stats["cost"] = best_cost
        return np.vstack([tree.branch(best_node), goals[best_goal]]), stats

    @staticmethod
    def _shift_costs(tree: Tree, root: int, delta: float) -> None:
        """Lower the cost of `root` and every descendant by the rewiring gain."""
        stack = [root]
        children = tree.parent[: tree.n]
        while stack:
            i = stack.pop()
            tree.cost[i] += delta
            stack.extend(np.nonzero(children == i)[0].tolist())
