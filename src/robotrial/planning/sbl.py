"""SBL (Sánchez and Latombe 2001): single-query bidirectional planning with lazy
collision checking. Two EST-style trees add nodes checking only the nodes themselves;
edges are checked only when a start-to-goal path appears, and a blocked edge cuts its
subtree off so the trees grow again.

Layer 3.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from robotrial.planning.base import Checker, Planner, Problem, Tree
from robotrial.planning.est import _Density


class SBL(Planner):
    name = "sbl"

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        step = self.step_size(checker)
        trees = [Tree(problem.start), Tree(problem.goals)]
        alive = [np.ones(1, dtype=bool), np.ones(len(problem.goals), dtype=bool)]
        checked = [{0}, set(range(len(problem.goals)))]  # nodes whose parent edge is verified
        dens = [_Density(checker, rng), _Density(checker, rng)]
        dens[0].add(problem.start)
        for g in problem.goals:
            dens[1].add(g)
        it, cuts = 0, 0
        while time.perf_counter() < deadline:
            it += 1
            a = it % 2
            ta, tb = trees[a], trees[1 - a]
            i = dens[a].pick(rng)
            if not alive[a][i]:
                continue
            target = np.clip(ta.q[i] + rng.uniform(-step, step, ta.d), checker.lower, checker.upper)
            if not checker.valid(target[None])[0]:
                continue
            new = ta.add(target, i)
            dens[a].add(target)
            alive[a] = np.append(alive[a], True)
            live = np.nonzero(alive[1 - a][: tb.n])[0]
            dist = np.linalg.norm(tb.q[live] - target, axis=1)
            j = int(live[np.argmin(dist)])
            if np.min(dist) > step:
                continue
            # a candidate path: check its unchecked edges lazily, first the bridge
            if not checker.motions_valid(target[None], tb.q[j][None])[0]:
                continue
            blocked = False
            for t, node in ((a, new), (1 - a, j)):
                tree = trees[t]
                k = node
                while tree.parent[k] >= 0:
                    p = int(tree.parent[k])
                    if k not in checked[t]:
                        if checker.motions_valid(tree.q[p][None], tree.q[k][None])[0]:
                            checked[t].add(k)
                        else:
                            self._cut(tree, alive[t], k)
                            cuts += 1
                            blocked = True
                            break
                    k = p
                if blocked:
                    break
            if blocked:
                continue
            path = np.vstack([ta.branch(new), tb.branch(j)[::-1]])
            if a == 1:
                path = path[::-1]
            return path, {"iterations": it, "nodes": ta.n + tb.n, "cut_edges": cuts}
        return None, {"iterations": it, "nodes": trees[0].n + trees[1].n, "cut_edges": cuts}

    @staticmethod
    def _cut(tree: Tree, alive: np.ndarray, root: int) -> None:
        """Remove node `root` and its descendants from the search."""
        stack = [root]
        parents = tree.parent[: tree.n]
        while stack:
            k = stack.pop()
            alive[k] = False
            tree.q[k] = np.inf  # never nearest again
            stack.extend(np.nonzero(parents == k)[0].tolist())
