"""EST (Hsu, Latombe and Motwani 1997) and its bidirectional form BiEST: trees that
expand from nodes chosen with probability inversely proportional to how crowded their
neighbourhood is, toward a random point near the chosen node.

Layer 3. Density is counted in a coarse grid over a random 2D projection of the joint
space, as OMPL's projection-based variants do.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from robotrial.planning.base import Checker, Planner, Problem, Tree, steer


class _Density:
    """Node counts per cell of a 2D random projection, to pick sparse nodes."""

    def __init__(self, checker: Checker, rng: np.random.Generator, cells: int = 20) -> None:
        self.proj = rng.normal(size=(checker.d, 2))
        corners = np.array([checker.lower, checker.upper])
        span = np.abs(self.proj).T @ (corners[1] - corners[0])
        self.lo = corners[0] @ self.proj - span
        self.size = 2 * span / cells + 1e-12
        self.counts: dict[tuple[int, int], int] = {}
        self.cell_of: list[tuple[int, int]] = []

    def add(self, q: np.ndarray) -> None:
        c = tuple(((q @ self.proj - self.lo) // self.size).astype(int))
        self.counts[c] = self.counts.get(c, 0) + 1  # type: ignore[index]
        self.cell_of.append(c)  # type: ignore[arg-type]

    def pick(self, rng: np.random.Generator) -> int:
        w = np.array([1.0 / self.counts[c] for c in self.cell_of])
        return int(rng.choice(len(w), p=w / w.sum()))


def _grow(tree: Tree, dens: _Density, checker: Checker, rng, step: float) -> int:
    """One EST expansion; returns the new node or -1."""
    i = dens.pick(rng)
    target = tree.q[i] + rng.uniform(-step, step, size=tree.d)
    target = np.clip(target, checker.lower, checker.upper)
    q_new = steer(tree.q[i], target, step)
    if not checker.motions_valid(tree.q[i][None], q_new[None])[0]:
        return -1
    dens.add(q_new)
    return tree.add(q_new, i)


class EST(Planner):
    name = "est"

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        step = self.step_size(checker)
        tree, dens = Tree(problem.start), _Density(checker, rng)
        dens.add(problem.start)
        goals = problem.goals
        it = 0
        while time.perf_counter() < deadline:
            it += 1
            new = _grow(tree, dens, checker, rng, step)
            if new < 0:
                continue
            gd = np.linalg.norm(goals - tree.q[new], axis=1)
            g = int(np.argmin(gd))
            near_goal = gd[g] <= step or rng.random() < self.goal_bias
            if near_goal and checker.motions_valid(tree.q[new][None], goals[g][None])[0]:
                return np.vstack([tree.branch(new), goals[g]]), {"iterations": it, "nodes": tree.n}
        return None, {"iterations": it, "nodes": tree.n}


class BiEST(Planner):
    name = "biest"

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        step = self.step_size(checker)
        trees = [Tree(problem.start), Tree(problem.goals)]
        dens = [_Density(checker, rng), _Density(checker, rng)]
        dens[0].add(problem.start)
        for g in problem.goals:
            dens[1].add(g)
        it = 0
        while time.perf_counter() < deadline:
            it += 1
            a = it % 2
            ta, tb = trees[a], trees[1 - a]
            new = _grow(ta, dens[a], checker, rng, step)
            if new < 0:
                continue
            j = tb.nearest(ta.q[new])
            close = np.linalg.norm(tb.q[j] - ta.q[new]) <= step
            if close and checker.motions_valid(ta.q[new][None], tb.q[j][None])[0]:
                path = np.vstack([ta.branch(new), tb.branch(j)[::-1]])
                if a == 1:
                    path = path[::-1]
                return path, {"iterations": it, "nodes": ta.n + tb.n}
        return None, {"iterations": it, "nodes": trees[0].n + trees[1].n}
