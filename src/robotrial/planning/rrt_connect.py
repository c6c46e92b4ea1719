"""RRTConnect (Kuffner and LaValle 2000): two trees, one from the start and one from the
goals, each extending toward a random sample and the other greedily connecting to it.

Layer 3. The default planner: the fastest on the arm tasks, like in MoveIt.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from robotrial.planning.base import Checker, Planner, Problem, Tree, sample, steer


class RRTConnect(Planner):
    name = "rrt_connect"

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        step = self.step_size(checker)
        ta, tb = Tree(problem.start), Tree(problem.goals)
        a_is_start = True
        it = 0
        while time.perf_counter() < deadline:
            it += 1
            target = sample(rng, checker)
            near = ta.nearest(target)
            q_new = steer(ta.q[near], target, step)
            if not checker.motions_valid(ta.q[near][None], q_new[None])[0]:
                ta, tb, a_is_start = tb, ta, not a_is_start
                continue
            new = ta.add(q_new, near)
            # connect: tb grows toward q_new until it reaches it or is blocked
            j = tb.nearest(q_new)
            while True:
                q_next = steer(tb.q[j], q_new, step)
                if not checker.motions_valid(tb.q[j][None], q_next[None])[0]:
                    break
                j = tb.add(q_next, j)
                if np.array_equal(q_next, q_new):
                    pa, pb = ta.branch(new), tb.branch(j)[::-1][1:]
                    path = np.vstack([pa, pb])
                    if not a_is_start:
                        path = path[::-1]
                    return path, {"iterations": it, "nodes": ta.n + tb.n}
            ta, tb, a_is_start = tb, ta, not a_is_start
        return None, {"iterations": it, "nodes": ta.n + tb.n}
