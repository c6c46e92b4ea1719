"""PRM (Kavraki et al. 1996) and PRM* (Karaman and Frazzoli 2011): a roadmap of free
samples joined to their nearest neighbours, searched with A* once the start and a goal
share a component. PRM* picks the neighbour count from the roadmap's size.

Layer 3. The roadmap grows in batches so that collision checks run batched.
"""

from __future__ import annotations

import heapq
import math
import time
from typing import Any

import numpy as np

from robotrial.planning.base import Checker, Planner, Problem


class _Components:
    """Union-find over roadmap vertices."""

    def __init__(self) -> None:
        self.up: list[int] = []

    def add(self) -> None:
        self.up.append(len(self.up))

    def find(self, i: int) -> int:
        while self.up[i] != i:
            self.up[i] = self.up[self.up[i]]
            i = self.up[i]
        return i

    def join(self, a: int, b: int) -> None:
        self.up[self.find(a)] = self.find(b)


class PRM(Planner):
    name = "prm"

    def __init__(self, neighbours: int = 10, batch: int = 64, star: bool = False) -> None:
        super().__init__()
        self.neighbours = int(neighbours)
        self.batch = int(batch)
        self.star = bool(star)

    def _k(self, n: int, d: int) -> int:
        if not self.star:
            return self.neighbours
        return max(1, math.ceil(math.e * (1.0 + 1.0 / d) * math.log(max(n, 2))))

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        d = checker.d
        verts = [problem.start, *problem.goals]
        q = np.array(verts)
        n = len(q)
        edges: list[dict[int, float]] = [{} for _ in range(n)]
        comp = _Components()
        for _ in range(n):
            comp.add()
        goal_ids = list(range(1, n))
        pending = list(range(n))  # vertices not yet connected to their neighbours
        checks = 0
        while time.perf_counter() < deadline:
            new = rng.uniform(checker.lower, checker.upper, size=(self.batch, d))
            new = new[checker.valid(new)]
            first = len(q)
            q = np.vstack([q, new])
            for _ in range(len(new)):
                edges.append({})
                comp.add()
            pending.extend(range(first, len(q)))
            a_list, b_list, pairs = [], [], []
            k = self._k(len(q), d)
            for i in pending:
                dist = np.linalg.norm(q - q[i], axis=1)
                dist[i] = np.inf
                for j in np.argsort(dist)[:k]:
                    j = int(j)
                    if j in edges[i] or (comp.find(i) == comp.find(j) and not self.star):
                        continue
                    a_list.append(q[i])
                    b_list.append(q[j])
                    pairs.append((i, j, float(dist[j])))
            pending = []
            if pairs:
                ok = checker.motions_valid(np.array(a_list), np.array(b_list))
                checks += len(pairs)
                for (i, j, w), good in zip(pairs, ok, strict=True):
                    if good:
                        edges[i][j] = w
                        edges[j][i] = w
                        comp.join(i, j)
            reached = [g for g in goal_ids if comp.find(g) == comp.find(0)]
            if reached:
                path = _astar(q, edges, 0, set(reached))
                return path, {"vertices": len(q), "edge_checks": checks, "nodes": len(q)}
        return None, {"vertices": len(q), "edge_checks": checks, "nodes": len(q)}


class PRMStar(PRM):
    name = "prm_star"

    def __init__(self, batch: int = 64) -> None:
        super().__init__(batch=batch, star=True)


def _astar(q: np.ndarray, edges: list[dict[int, float]], start: int, goals: set[int]) -> np.ndarray:
    """Shortest roadmap path from `start` to the nearest of `goals` (A*, Euclidean heuristic)."""
    gq = q[sorted(goals)]

    def h(i: int) -> float:
        return float(np.min(np.linalg.norm(gq - q[i], axis=1)))

    best = {start: 0.0}
    came: dict[int, int] = {}
    heap = [(h(start), start)]
    done = set()
    while heap:
        _, i = heapq.heappop(heap)
        if i in done:
            continue
        done.add(i)
        if i in goals:
            out = [i]
            while out[-1] in came:
                out.append(came[out[-1]])
            return q[out[::-1]]
        for j, w in edges[i].items():
            c = best[i] + w
            if c < best.get(j, math.inf):
                best[j] = c
                came[j] = i
                heapq.heappush(heap, (c + h(j), j))
    raise RuntimeError("roadmap components said connected but no path was found")
