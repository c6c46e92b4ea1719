"""RRTConnect (Kuffner and LaValle 2000): two trees, one from the start and one from the
goals, each extending toward a random sample and the other greedily connecting to it.

Three refinements OMPL's RRTConnect does not make, all on by default:
- balanced trees: the smaller tree is the one extended (on ties they alternate), so a
  goal tree boxed in by a shelf or a box keeps growing instead of waiting its turn while
  the start tree fills the open space;
- dynamic domains (Yershova et al. 2005): a node whose extension hit an obstacle only
  takes samples within a radius of it (4 ranges, shrinking by 0.01 % per failure to
  one range, growing back by as much per success), so nodes against a wall stop
  drawing the samples that lie behind it;
- boxed-in trees: a tree of a few nodes that has not grown for `STALL` iterations
  (a start or goal in a shelf's pocket, whose nodes' domains refuse nearly every sample
  and whose full-range extensions run into a board) draws each refused sample again
  within the domain of one of its nodes, and each of its nodes halves its step on a
  failed extension (to a quarter range) and doubles it on a success. On
  MotionBenchMaker's bookshelves this took the slowest 5 % from 11,000-220,000
  iterations to a few thousand; trees that grow (the cage's) keep the full range, where
  shorter steps cost more than they save.

The samples follow the Halton sequence, each element made from the last by a carry
through its digits. Its default range is shorter than OMPL's (0.075 of the joint space's
diagonal against 0.2; 1.0 rad for the Panda, as VAMP's): with dynamic domains of a few
ranges, short extensions fail less often in cluttered scenes and a failed one costs
less. On MotionBenchMaker's cage it needs a fifth of the iterations of OMPL's range.

Layer 3. The default planner: the fastest on the arm tasks, as in MoveIt. With a checker
that offers compiled kernels (the sphere model), the whole loop (sampling, nearest
neighbour, extension, connection, collision checks) runs compiled in chunks of
iterations between time checks; with any other checker it runs in Python.
"""

from __future__ import annotations

import math
import random
import threading
import time
from typing import Any

import numba as nb
import numpy as np

from robotrial.collision.kernels import LANES, config_free, configs_free, model, motion_free
from robotrial.planning.base import (
    Checker,
    Planner,
    PlanResult,
    Problem,
    Tree,
    default_range,
    sample,
    steer,
)

CHUNK = 256  # iterations per compiled call between deadline checks
RANGE = 0.075  # the default range, as a fraction of the joint space's diagonal
DOMAIN_RADIUS = 4.0  # a node's first domain after a failed extension, in ranges
DOMAIN_FLOOR = 1.0  # the smallest domain, in ranges
DOMAIN_RATE = 1e-4  # how much a domain shrinks per failure and grows per success
STALL = 100  # iterations of a tree without a new node after which it counts as boxed in
SMALL_TREE = 32  # ... if it has no more nodes than this
STEP_FLOOR = 0.25  # the shortest step of a boxed-in tree's node, in ranges


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
        for j in range(a.shape[0]):
            out[j] = b[j]
        return True
    f = step / dist
    for j in range(a.shape[0]):
        out[j] = a[j] + f * (b[j] - a[j])
    return False


_PRIMES = np.array([2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71])


@nb.njit(cache=True, inline="always")
def _halton_start(i, base, digits) -> float:
    """Element i of the van der Corput sequence in `base` (one coordinate of the Halton
    sequence, whose points fill the space more evenly than independent draws); its
    digits, lowest first, go to `digits` for `_halton_next`."""
    f, r = 1.0, 0.0
    k = 0
    while i > 0:
        f /= base
        digits[k] = i % base
        r += f * digits[k]
        i //= base
        k += 1
    for m in range(k, digits.shape[0]):
        digits[m] = 0
    return r


@nb.njit(cache=True, inline="always")
def _halton_next(r, base, digits) -> float:
    """The element after `r` in the sequence whose digits are `digits` (updated): a
    carry through the digits, 1 / (`base` - 1) of a digit an element on average, where
    computing an element anew takes a division per digit (a quarter of a microsecond
    for a Panda sample)."""
    k = 0
    f = 1.0 / base
    cleared = 0.0  # the value of the digits carried over, base - 1 each
    while digits[k] == base - 1:
        digits[k] = 0
        cleared += f * (base - 1)
        k += 1
        f /= base
    digits[k] += 1
    return r - cleared + f


@nb.njit(cache=True, inline="always")
def _add(tq, tpar, trad, tstp, n, q, parent, stp) -> None:
    """Make node n of a tree: configuration q, its parent, no domain yet, its step."""
    for j in range(q.shape[0]):
        tq[n, j] = q[j]
    tpar[n] = parent
    trad[n] = np.inf
    tstp[n] = stp


@nb.njit(cache=True, _nrt=False, nogil=True)
def _grow(first, start, goals, seed, work, digits, trees, t_is_start, params, iters, checks, path):
    """Run up to `iters` RRTConnect iterations on `trees`: (nodes, parents, domain radii,
    steps) of tree t, extended first, the same of tree u, and counts = [n_t, n_u,
    iterations done, t's and u's iterations since they last grew, points of the path],
    updated in place. `params` (`_params`): balance the trees, the domains' first radius
    and floor in ranges (no dynamic domains with a radius of 0), their rate, unstick,
    the range (0: `RANGE` of the joint space's diagonal). `work`: rows for the sample,
    two new nodes and the sampler's state, whose digits are `digits`. `checks` is the
    checker's `kernel_args()`. An iteration whose sample falls outside its nearest
    node's domain checks nothing, unless its tree is boxed in (see the module's
    docstring).
    Returns (status, path length, t_is_start): status 1 when the trees met, 0 when the
    iterations ran out, -1 when a tree is full. With `first`, the query starts here:
    seed the generator, check the ends, fill the roots of tq (the start) and uq (the
    free goals), try the direct motion; status 2 when that motion is free, -2 for a
    start in contact, -3 when no goal is free. On 1 and 2 the path, start to goal, is
    in path[:counts[5]].
    """
    tq, tpar, trad, tstp, uq, upar, urad, ustp, counts = trees
    floats, ints, scratch, items = checks
    lower, upper = _bounds(floats, ints)
    step = _step(params[5], lower, upper)
    balance, r0, floor, rate = params[0] > 0.0, params[1] * step, params[2] * step, params[3]
    unstick, least = params[4] > 0.0, STEP_FLOOR * step
    target, q_new, q_next, halton = work[0], work[1], work[2], work[3]
    d = lower.shape[0]
    if first:
        np.random.seed(seed)  # noqa: NPY002 (numba has only the legacy generator)
        # the start and the first goals in one block; each alone only if one is in contact
        n0 = min(goals.shape[0], LANES - 1)
        for j in range(d):
            path[0, j] = start[j]
            for g in range(n0):
                path[1 + g, j] = goals[g, j]
        together = configs_free(floats, ints, scratch, items, path, 1 + n0)
        if not together and not config_free(floats, ints, scratch, items, start):
            return -2, 0.0, t_is_start
        _add(tq, tpar, trad, tstp, 0, start, -1, step)
        ng = 0
        for g in range(goals.shape[0]):
            if (together and g < n0) or config_free(floats, ints, scratch, items, goals[g]):
                _add(uq, upar, urad, ustp, ng, goals[g], -1, step)
                ng += 1
        counts[0], counts[1], counts[2], counts[3], counts[4] = 1, ng, 0, 0, 0
        at = 1 + np.random.randint(0, 1 << 20)  # noqa: NPY002 (where the sequence starts)
        for j in range(d):
            halton[j] = _halton_start(at, _PRIMES[j], digits[j])
        if ng == 0:
            return -3, 0.0, t_is_start
        if motion_free(floats, ints, scratch, items, start, uq[0]):
            for j in range(d):
                path[0, j], path[1, j] = start[j], uq[0, j]
            counts[5] = 2
            return 2, _distance(start, uq[0]), t_is_start
    nt, nu, st, su = counts[0], counts[1], counts[3], counts[4]
    cap = tq.shape[0]
    for _ in range(iters):
        counts[2] += 1
        if nt >= cap or nu >= cap:
            counts[0], counts[1], counts[3], counts[4] = nt, nu, st, su
            return -1, 0.0, t_is_start
        for j in range(d):
            halton[j] = _halton_next(halton[j], _PRIMES[j], digits[j])
            target[j] = lower[j] + halton[j] * (upper[j] - lower[j])
        near = _nearest(tq, nt, target)
        stuck = unstick and st >= STALL and nt <= SMALL_TREE
        st += 1
        if stuck and _distance(tq[near], target) > trad[near]:
            # refused: draw again around a node of this tree, within its domain
            j = np.random.randint(0, nt)  # noqa: NPY002
            r = min(trad[j], r0)
            for jj in range(d):
                x = tq[j, jj] + r * (2.0 * np.random.random() - 1.0)  # noqa: NPY002
                target[jj] = min(max(x, lower[jj]), upper[jj])
            near = _nearest(tq, nt, target)
        if _distance(tq[near], target) <= trad[near]:
            s = tstp[near] if stuck else step
            _steer(tq[near], target, s, q_new)
            if motion_free(floats, ints, scratch, items, tq[near], q_new):
                if trad[near] < np.inf:
                    trad[near] *= 1.0 + rate
                if stuck:
                    s = min(step, 2.0 * s)
                    tstp[near] = s
                st = 0
                _add(tq, tpar, trad, tstp, nt, q_new, near, s)
                new = nt
                nt += 1
                k = _nearest(uq, nu, q_new)
                while nu < cap:
                    reached = _steer(uq[k], q_new, step, q_next)
                    if not motion_free(floats, ints, scratch, items, uq[k], q_next):
                        break
                    _add(uq, upar, urad, ustp, nu, q_next, k, step)
                    k = nu
                    nu += 1
                    if reached:
                        counts[0], counts[1], counts[3], counts[4] = nt, nu, st, su
                        if t_is_start:
                            n, length = _join(tq, tpar, new, uq, upar, k, path)
                        else:
                            n, length = _join(uq, upar, k, tq, tpar, new, path)
                        counts[5] = n
                        return 1, length, t_is_start
            else:
                if r0 > 0.0:
                    trad[near] = (
                        r0 if trad[near] == np.inf else max(floor, trad[near] * (1.0 - rate))
                    )
                if stuck:
                    tstp[near] = max(least, 0.5 * s)
        if not balance or nu <= nt:  # swap the trees' roles
            tq, uq = uq, tq
            tpar, upar = upar, tpar
            trad, urad = urad, trad
            tstp, ustp = ustp, tstp
            nt, nu = nu, nt
            st, su = su, st
            t_is_start = not t_is_start
    counts[0], counts[1], counts[3], counts[4] = nt, nu, st, su
    return 0, 0.0, t_is_start


@nb.njit(cache=True, inline="always")
def _bounds(floats, ints):
    """The joint limits from a packed checker."""
    m = model(floats, ints)
    return m.lower, m.upper


@nb.njit(cache=True, inline="always")
def _step(given, lower, upper) -> float:
    """The range: `given`, else `RANGE` of the joint space's diagonal."""
    if given > 0.0:
        return given
    d2 = 0.0
    for j in range(lower.shape[0]):
        d2 += (np.float64(upper[j]) - np.float64(lower[j])) ** 2
    return RANGE * np.sqrt(d2)


class _Workspace:
    """The compiled loop's trees and the path's room, kept between queries (allocating
    them anew cost a tenth of a short query): one per thread and dimension, so a query
    runs at a time in each."""

    def __init__(self, d: int, goals: int) -> None:
        cap = max(1024, goals)
        self.trees = [np.empty((cap, d)), np.empty((cap, d))]
        self.parents = [np.full(cap, -1, dtype=np.int64), np.full(cap, -1, dtype=np.int64)]
        self.radii = [np.full(cap, np.inf), np.full(cap, np.inf)]
        self.steps = [np.empty(cap), np.empty(cap)]
        self.counts = np.zeros(6, dtype=np.int64)
        self.work = np.empty((4, d))
        self.digits = np.zeros((d, 64), dtype=np.int64)  # the sampler's, per joint
        self.path = np.empty((2 * cap, d))

    def grow(self) -> None:
        """Double both trees (a query filled one)."""
        for k in (0, 1):
            n, d = self.trees[k].shape
            self.trees[k] = np.vstack([self.trees[k], np.empty((n, d))])
            self.parents[k] = np.concatenate([self.parents[k], np.full(n, -1, dtype=np.int64)])
            self.radii[k] = np.concatenate([self.radii[k], np.full(n, np.inf)])
            self.steps[k] = np.concatenate([self.steps[k], np.empty(n)])
        self.path = np.empty((2 * len(self.trees[0]), self.path.shape[1]))


_LOCAL = threading.local()


def _workspace(d: int, goals: int) -> _Workspace:
    spaces = _LOCAL.__dict__.setdefault("spaces", {})
    ws = spaces.get(d)
    if ws is None or len(ws.trees[0]) < goals:
        ws = spaces[d] = _Workspace(d, goals)
    return ws


class RRTConnect(Planner):
    """`balance`: extend the smaller tree; `dynamic_domain`: limit where a node that hit an
    obstacle takes samples; `unstick`: help a boxed-in tree out (see the module's
    docstring). All three off is OMPL's RRTConnect."""

    name = "rrt_connect"

    def __init__(
        self,
        range: float = 0.0,
        goal_bias: float = 0.05,
        balance: bool = True,
        dynamic_domain: bool = True,
        unstick: bool = True,
    ) -> None:
        super().__init__(range, goal_bias)
        self.balance = balance
        self.dynamic_domain = dynamic_domain
        self.unstick = unstick
        # the compiled loop's `params`, the domains in ranges (its range is worked out
        # there: a norm in numpy costs a cold query 40 us)
        self._params = np.array(
            [
                float(balance),
                DOMAIN_RADIUS if dynamic_domain else 0.0,
                DOMAIN_FLOOR,
                DOMAIN_RATE,
                float(unstick),
                self.range,
            ]
        )

    def step_size(self, checker: Checker) -> float:
        """The range given, else `RANGE` of the joint space's diagonal."""
        return self.range if self.range > 0 else default_range(checker) * RANGE / 0.2

    def solve(self, problem: Problem, checker: Checker) -> PlanResult:
        """With the sphere checker, the whole query (end checks, direct motion, the
        tree loop, the path) runs compiled; one call to the kernel for every `CHUNK`
        iterations. The Python around it is kept short: a query's first microseconds
        run from caches other work has cooled, where each line costs several."""
        t0 = time.perf_counter()
        # not isinstance(checker, CompiledChecker): a protocol check costs 20-90 us
        kernel_args = getattr(checker, "kernel_args", None)
        if kernel_args is None:
            return super().solve(problem, checker)
        checks = tuple(kernel_args())  # plain: numba types it faster
        ws = _workspace(checker.d, len(problem.goals))
        trees, parents, radii, steps = ws.trees, ws.parents, ws.radii, ws.steps
        counts = ws.counts
        seed = problem.seed
        seed = (random.getrandbits(31) if seed is None else seed) & 0x7FFFFFFF
        t = 0  # the tree extended first in the next chunk
        first = True
        while True:
            u = 1 - t
            status, length, t_is_start = _grow(
                first,
                problem.start,
                problem.goals,
                seed,
                ws.work,
                ws.digits,
                (
                    trees[t],
                    parents[t],
                    radii[t],
                    steps[t],
                    trees[u],
                    parents[u],
                    radii[u],
                    steps[u],
                    counts,
                ),
                t == 0,
                self._params,
                CHUNK,
                checks,
                ws.path,
            )
            if status > 0:
                stats = {"planner": self.name, "iterations": int(counts[2])}
                if status == 2:
                    stats["direct"] = True
                else:
                    stats["nodes"] = int(counts[0] + counts[1])
                stats["planning_time"] = time.perf_counter() - t0
                stats["path_length"] = length
                return PlanResult(True, ws.path[: counts[5]].copy(), "solved", stats)
            if status < -1:
                stats = {"planning_time": time.perf_counter() - t0}
                reason = "invalid_start" if status == -2 else "invalid_goal"
                return PlanResult(False, problem.start[None], reason, stats)
            first = False
            # the kernel swaps roles as it goes; its last "t" is the start tree or not
            t = 0 if t_is_start else 1
            if status == -1:
                ws.grow()
            if time.perf_counter() >= t0 + problem.time_limit:
                stats = {
                    "planner": self.name,
                    "iterations": int(counts[2]),
                    "nodes": int(counts[0] + counts[1]),
                    "planning_time": time.perf_counter() - t0,
                }
                return PlanResult(False, problem.start[None], "timeout", stats)

    def _solve(
        self, problem: Problem, checker: Checker, rng: np.random.Generator, deadline: float
    ) -> tuple[np.ndarray | None, dict[str, Any]]:
        return self._solve_python(problem, checker, rng, deadline)

    def _solve_python(self, problem, checker, rng, deadline):
        """The compiled loop's algorithm over any checker; the domains of the nodes that
        hit an obstacle and the steps of a boxed-in tree's nodes are kept by node."""
        step = self.step_size(checker)
        _, r0, floor, rate, unstick, _ = self._params
        r0, floor = r0 * step, floor * step
        ta, tb = Tree(problem.start), Tree(problem.goals)
        da: dict[int, float] = {}
        db: dict[int, float] = {}
        sa: dict[int, float] = {}
        sb: dict[int, float] = {}
        stall_a = stall_b = 0
        a_is_start = True
        it = 0
        while time.perf_counter() < deadline:
            it += 1
            target = sample(rng, checker)
            near = ta.nearest(target)
            stuck = unstick > 0.0 and stall_a >= STALL and ta.n <= SMALL_TREE
            stall_a += 1
            if stuck and math.dist(ta.q[near], target) > da.get(near, math.inf):
                j = int(rng.integers(ta.n))
                r = min(da.get(j, math.inf), r0)
                target = np.clip(ta.q[j] + rng.uniform(-r, r, ta.d), checker.lower, checker.upper)
                near = ta.nearest(target)
            radius = da.get(near, math.inf)
            if math.dist(ta.q[near], target) <= radius:
                s = sa.get(near, step) if stuck else step
                q_new = steer(ta.q[near], target, s)
                if checker.motions_valid(ta.q[near][None], q_new[None])[0]:
                    if near in da:
                        da[near] = radius * (1.0 + rate)
                    new = ta.add(q_new, near)
                    stall_a = 0
                    if stuck:
                        sa[near] = sa[new] = min(step, 2.0 * s)
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
                else:
                    if r0 > 0.0:
                        da[near] = r0 if near not in da else max(floor, radius * (1.0 - rate))
                    if stuck:
                        sa[near] = max(STEP_FLOOR * step, 0.5 * s)
            if not self.balance or tb.n <= ta.n:
                ta, tb, da, db, sa, sb = tb, ta, db, da, sb, sa
                stall_a, stall_b = stall_b, stall_a
                a_is_start = not a_is_start
        return None, {"iterations": it, "nodes": ta.n + tb.n}


@nb.njit(cache=True, _nrt=False, nogil=True)
def _join(tq0, par0, i0, tq1, par1, i1, out) -> tuple[int, float]:
    """Write the path root of tree 0 -> node i0 = node i1 -> root of tree 1 into `out`;
    returns its number of points and its joint-space length."""
    n = 0
    i = i0
    while i >= 0:  # count the start branch, then write it backwards
        n += 1
        i = par0[i]
    i = i0
    for k in range(n - 1, -1, -1):
        for j in range(tq0.shape[1]):
            out[k, j] = tq0[i, j]
        i = par0[i]
    i = par1[i1]
    while i >= 0:
        for j in range(tq1.shape[1]):
            out[n, j] = tq1[i, j]
        n += 1
        i = par1[i]
    length = 0.0
    for k in range(1, n):
        length += _distance(out[k - 1], out[k])
    return n, length
