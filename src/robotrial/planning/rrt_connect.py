"""RRTConnect (Kuffner and LaValle 2000): two trees, one from the start and one from the
goals, each extending toward a random sample and the other greedily connecting to it.

Layer 3. The default planner: the fastest on the arm tasks, as in MoveIt. With a checker
that offers compiled kernels (the sphere model), the whole loop (sampling, nearest
neighbour, extension, connection, collision checks) runs compiled in chunks of
iterations between time checks; with any other checker it runs in Python.
"""

from __future__ import annotations

import time
from typing import Any

import numba as nb
import numpy as np

from robotrial.collision.kernels import segment_clearance
from robotrial.planning.base import Checker, Planner, Problem, Tree, sample, steer

CHUNK = 256  # iterations per compiled call between deadline checks


@nb.njit(cache=True)
def _seed(seed: int) -> None:
    np.random.seed(seed)  # noqa: NPY002 (numba has only the legacy generator)


@nb.njit(cache=True, inline="always")
def _nearest(tq, n, q) -> int:
    best, best_d = 0, np.inf
    for i in range(n):
        d2 = 0.0
        for j in range(q.shape[0]):
            e = tq[i, j] - q[j]
            d2 += e * e
        if d2 < best_d:
            best, best_d = i, d2
    return best


@nb.njit(cache=True, inline="always")
def _distance(a, b) -> float:
    d2 = 0.0
    for j in range(a.shape[0]):
        d2 += (b[j] - a[j]) ** 2
    return np.sqrt(d2)


@nb.njit(cache=True, inline="always")
def _steer(a, b, step, out) -> bool:
    """out = the point `step` along a -> b (or b); True when b itself was reached."""
    d2 = 0.0
    for j in range(a.shape[0]):
        d2 += (b[j] - a[j]) ** 2
    dist = np.sqrt(d2)
    if dist <= step:
        out[:] = b
        return True
    f = step / dist
    for j in range(a.shape[0]):
        out[j] = a[j] + f * (b[j] - a[j])
    return False


@nb.njit(cache=True)
def _grow(
    tq,
    tpar,
    uq,
    upar,
    counts,
    t_is_start,
    lower,
    upper,
    step,
    iters,
    resolution,
    body_rate,
    pair_rate,
    kin,
    bodies,
    env_bodies,
    pairs,
    pad,
    env,
    buf,
):
    """Run up to `iters` RRTConnect iterations on trees t (tq, tpar) and u.

    counts = [n_t, n_u, iterations done] is updated in place. Returns (status, i_t, i_u,
    t_is_start): status 1 when node i_t of t and node i_u of u are the same point (the
    trees met), 0 when the iterations ran out, -1 when a tree is full.
    """
    d = lower.shape[0]
    scratch = np.empty(d)
    target = np.empty(d)
    q_new = np.empty(d)
    q_next = np.empty(d)
    nt, nu = counts[0], counts[1]
    cap = tq.shape[0]
    for _ in range(iters):
        counts[2] += 1
        if nt >= cap or nu >= cap:
            counts[0], counts[1] = nt, nu
            return -1, 0, 0, t_is_start
        for j in range(d):
            target[j] = lower[j] + np.random.random() * (upper[j] - lower[j])  # noqa: NPY002
        near = _nearest(tq, nt, target)
        _steer(tq[near], target, step, q_new)
        if 0.0 <= segment_clearance(
            tq[near],
            q_new,
            -1.0,
            resolution,
            body_rate,
            pair_rate,
            kin,
            bodies,
            env_bodies,
            pairs,
            pad,
            env,
            buf,
            scratch,
        ):
            tq[nt] = q_new
            tpar[nt] = near
            new = nt
            nt += 1
            k = _nearest(uq, nu, q_new)
            c_k = -1.0  # clearance at uq[k] along the walk, in units of one step
            while nu < cap:
                reached = _steer(uq[k], q_new, step, q_next)
                length = _distance(uq[k], q_next)
                if c_k >= 0.0 and length > 0.0:
                    c_k *= step / length  # the walk's last step may be shorter
                c_k = segment_clearance(
                    uq[k],
                    q_next,
                    c_k,
                    resolution,
                    body_rate,
                    pair_rate,
                    kin,
                    bodies,
                    env_bodies,
                    pairs,
                    pad,
                    env,
                    buf,
                    scratch,
                )
                if c_k < 0.0:
                    break
                uq[nu] = q_next
                upar[nu] = k
                k = nu
                nu += 1
                if reached:
                    counts[0], counts[1] = nt, nu
                    return 1, new, k, t_is_start
        # swap the trees' roles
        tq, uq = uq, tq
        tpar, upar = upar, tpar
        nt, nu = nu, nt
        t_is_start = not t_is_start
    counts[0], counts[1] = nt, nu
    return 0, 0, 0, t_is_start


class RRTConnect(Planner):
    name = "rrt_connect"

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        if hasattr(checker, "kernel_args"):
            return self._solve_compiled(problem, checker, rng, deadline)
        return self._solve_python(problem, checker, rng, deadline)

    def _solve_compiled(self, problem, checker, rng, deadline):
        step = self.step_size(checker)
        d = checker.d
        cap = 4096
        trees = [np.empty((cap, d)), np.empty((cap, d))]
        parents = [np.full(cap, -1, dtype=np.int64), np.full(cap, -1, dtype=np.int64)]
        trees[0][0] = problem.start
        ng = len(problem.goals)
        trees[1][:ng] = problem.goals
        n = [1, ng]  # nodes in trees[0] (start) and trees[1] (goals)
        counts = np.zeros(3, dtype=np.int64)
        _seed(int(rng.integers(1 << 31)))
        args = checker.kernel_args()  # type: ignore[attr-defined]
        lower = np.asarray(checker.lower, dtype=float)
        upper = np.asarray(checker.upper, dtype=float)
        t = 0  # the tree extended first in the next chunk
        while True:
            u = 1 - t
            counts[0], counts[1] = n[t], n[u]
            status, it, iu, t_is_start = _grow(
                trees[t],
                parents[t],
                trees[u],
                parents[u],
                counts,
                t == 0,
                lower,
                upper,
                step,
                CHUNK,
                *args,
            )
            # the kernel swaps roles as it goes; its last "t" is the start tree or not
            t = 0 if t_is_start else 1
            n[t], n[1 - t] = int(counts[0]), int(counts[1])
            stats = {"iterations": int(counts[2]), "nodes": n[0] + n[1]}
            if status == 1:
                i_start, i_goal = (it, iu) if t == 0 else (iu, it)
                a = _branch(trees[0], parents[0], i_start)
                b = _branch(trees[1], parents[1], i_goal)[::-1]
                return np.vstack([a, b[1:]]), stats
            if status == -1:
                for k in (0, 1):
                    trees[k] = np.vstack([trees[k], np.empty((cap, d))])
                    parents[k] = np.concatenate([parents[k], np.full(cap, -1, dtype=np.int64)])
                cap *= 2
            if time.perf_counter() >= deadline:
                return None, stats

    def _solve_python(self, problem, checker, rng, deadline):
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
            j = tb.nearest(q_new)
            while True:
                q_next = steer(tb.q[j], q_new, step)
                if not checker.motions_valid(tb.q[j][None], q_next[None])[0]:
                    break
                j = tb.add(q_next, j)
                if np.array_equal(q_next, q_new):
                    path = np.vstack([ta.branch(new), tb.branch(j)[::-1][1:]])
                    if not a_is_start:
                        path = path[::-1]
                    return path, {"iterations": it, "nodes": ta.n + tb.n}
            ta, tb, a_is_start = tb, ta, not a_is_start
        return None, {"iterations": it, "nodes": ta.n + tb.n}


def _branch(q: np.ndarray, parent: np.ndarray, i: int) -> np.ndarray:
    out = []
    while i >= 0:
        out.append(q[i])
        i = int(parent[i])
    return np.array(out[::-1])
