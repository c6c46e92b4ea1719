"""Pose-graph SLAM, Karto / slam_toolbox style (layer 3).

Front end: every scan is matched against the map built so far (the Gauss-Newton matcher
of matcher.py, from the previous pose); every `minimum_travel_distance` or
`minimum_travel_heading` the scan becomes a node of the graph, joined to the previous
node by an edge whose measurement is the matched relative pose and whose information is
the match's Hessian. Loop closure: for a new node, earlier nodes near its estimate but
not recent in the chain are candidates; the scan is matched correlatively (a brute
search over a window of poses on a likelihood field) against a small grid built from the
candidate's neighbouring scans, refined by Gauss-Newton, and accepted when the response
is high and the refinement agrees with the search. Back end: after every few accepted
closures a sparse Levenberg-Marquardt over the SE(2) node poses runs, and the map is
rebuilt from the scans at their optimised poses. Scans between nodes keep their pose
relative to the node before them, so the whole trajectory follows the optimisation.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np
from scipy import ndimage, sparse
from scipy.sparse.linalg import spsolve

from robotrial.slam.grid import LogOddsGrid, LogOddsModel
from robotrial.slam.matcher import ScanMatcher
from robotrial.slam.params import PoseGraphParams
from robotrial.slam.scan import Beams, compose, relative, transform_points, wrap


@dataclass(frozen=True)
class Edge:
    """A constraint: node j seen from node i at `z` (x, y, yaw in i's frame), with
    information `info` (3 x 3, in i's frame); `loop` marks a loop closure."""

    i: int
    j: int
    z: np.ndarray
    info: np.ndarray
    loop: bool = False


def _errors(poses: np.ndarray, ii: np.ndarray, jj: np.ndarray, z: np.ndarray) -> np.ndarray:
    pi, pj = poses[ii], poses[jj]
    c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
    dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
    e = np.empty((len(ii), 3))
    e[:, 0] = c * dx + s * dy - z[:, 0]
    e[:, 1] = -s * dx + c * dy - z[:, 1]
    e[:, 2] = (pj[:, 2] - pi[:, 2] - z[:, 2] + np.pi) % (2 * np.pi) - np.pi
    return e


def graph_cost(poses: np.ndarray, edges: list[Edge]) -> float:
    """Sum over edges of e' info e: zero when every constraint holds exactly."""
    if not edges:
        return 0.0
    ii = np.array([e.i for e in edges])
    jj = np.array([e.j for e in edges])
    z = np.array([e.z for e in edges], dtype=np.float64)
    info = np.array([e.info for e in edges], dtype=np.float64)
    err = _errors(np.asarray(poses, dtype=np.float64), ii, jj, z)
    return float(np.einsum("ei,eij,ej->", err, info, err))


def optimize_graph(
    poses: np.ndarray, edges: list[Edge], iterations: int = 20, fixed: int = 0
) -> tuple[np.ndarray, float, float]:
    """Sparse Levenberg-Marquardt over SE(2) poses (N, 3) with `fixed` held where it is
    (the gauge). Returns (optimised poses, cost before, cost after)."""
    x = np.asarray(poses, dtype=np.float64).copy()
    n = x.shape[0]
    if not edges or n < 2:
        c = graph_cost(x, edges)
        return x, c, c
    for e in edges:
        if not (0 <= e.i < n and 0 <= e.j < n) or e.i == e.j:
            raise ValueError(f"pose graph: edge ({e.i}, {e.j}) is not between two of {n} nodes")
    ii = np.array([e.i for e in edges])
    jj = np.array([e.j for e in edges])
    z = np.array([e.z for e in edges], dtype=np.float64)
    info = np.array([e.info for e in edges], dtype=np.float64)
    # Block row/column indices of the 3x3 blocks (i,i), (i,j), (j,i), (j,j) of every edge.
    k = np.arange(3)
    blocks = [(ii, ii), (ii, jj), (jj, ii), (jj, jj)]
    m = len(edges)
    rows = np.concatenate(
        [np.broadcast_to(3 * r[:, None, None] + k[None, :, None], (m, 3, 3)) for r, _ in blocks]
    ).ravel()
    cols = np.concatenate(
        [np.broadcast_to(3 * c[:, None, None] + k[None, None, :], (m, 3, 3)) for _, c in blocks]
    ).ravel()

    def cost_of(p: np.ndarray) -> float:
        err = _errors(p, ii, jj, z)
        return float(np.einsum("ei,eij,ej->", err, info, err))

    start = cost = cost_of(x)
    lam = 1e-4
    for _ in range(iterations):
        err = _errors(x, ii, jj, z)
        pi, pj = x[ii], x[jj]
        c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
        dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
        a = np.zeros((m, 3, 3))
        b = np.zeros((m, 3, 3))
        a[:, 0, 0], a[:, 0, 1], a[:, 0, 2] = -c, -s, -s * dx + c * dy
        a[:, 1, 0], a[:, 1, 1], a[:, 1, 2] = s, -c, -c * dx - s * dy
        a[:, 2, 2] = -1.0
        b[:, 0, 0], b[:, 0, 1] = c, s
        b[:, 1, 0], b[:, 1, 1] = -s, c
        b[:, 2, 2] = 1.0
        at, bt = a.transpose(0, 2, 1), b.transpose(0, 2, 1)
        hii, hij, hjj = at @ info @ a, at @ info @ b, bt @ info @ b
        vals = np.concatenate([hii, hij, hij.transpose(0, 2, 1), hjj]).ravel()
        h = sparse.coo_matrix((vals, (rows, cols)), shape=(3 * n, 3 * n)).tocsc()
        oe = np.einsum("eij,ej->ei", info, err)
        g = np.zeros(3 * n)
        np.add.at(g, (ii[:, None] * 3 + k).ravel(), np.einsum("eji,ej->ei", a, oe).ravel())
        np.add.at(g, (jj[:, None] * 3 + k).ravel(), np.einsum("eji,ej->ei", b, oe).ravel())
        diag = h.diagonal()
        anchor = np.zeros(3 * n)
        anchor[3 * fixed : 3 * fixed + 3] = 1e12
        while True:
            damp = sparse.diags(lam * (diag + 1e-9) + anchor)
            step = spsolve((h + damp).tocsc(), -g).reshape(n, 3)
            step[fixed] = 0.0
            trial = x + step
            trial[:, 2] = (trial[:, 2] + np.pi) % (2 * np.pi) - np.pi
            new = cost_of(trial)
            if new <= cost:
                x, lam = trial, max(lam / 10, 1e-9)
                break
            lam *= 10
            if lam > 1e6:
                return x, start, cost
        done = cost - new < 1e-9 * max(cost, 1e-12) or np.abs(step).max() < 1e-7
        cost = new
        if done:
            break
    return x, start, cost


def likelihood_field(grid: LogOddsGrid, sigma: float) -> np.ndarray:
    """A smooth score per cell, 1 on a wall and falling off over about `sigma` m: the
    occupied cells blurred by a Gaussian and scaled so that a straight wall peaks at 1
    (a separable filter, much cheaper than a distance transform on a whole room)."""
    occ = (grid.logodds > 0).astype(np.float32)
    if not occ.any():
        return np.zeros(grid.shape)
    s = sigma / grid.resolution
    blurred = ndimage.gaussian_filter(occ, s, truncate=3.0)
    return np.minimum(1.0, blurred * np.sqrt(2 * np.pi) * s)


@numba.njit(cache=True, nogil=True)
def _correlate(
    field: np.ndarray,
    ox: float,
    oy: float,
    res: float,
    pts: np.ndarray,
    gx: float,
    gy: float,
    yaws: np.ndarray,
    steps: int,
) -> tuple[int, int, int, float]:
    rows, cols = field.shape
    n = pts.shape[0]
    best, ba, bi, bj = -1.0, 0, 0, 0
    rr = np.empty(n, np.int64)
    cc = np.empty(n, np.int64)
    for a in range(yaws.shape[0]):
        c, s = np.cos(yaws[a]), np.sin(yaws[a])
        for k in range(n):
            cc[k] = int(np.floor((gx + c * pts[k, 0] - s * pts[k, 1] - ox) / res))
            rr[k] = int(np.floor((gy + s * pts[k, 0] + c * pts[k, 1] - oy) / res))
        for i in range(-steps, steps + 1):
            for j in range(-steps, steps + 1):
                total = 0.0
                for k in range(n):
                    r = rr[k] + i
                    q = cc[k] + j
                    if 0 <= r < rows and 0 <= q < cols:
                        total += field[r, q]
                if total > best:
                    best, ba, bi, bj = total, a, i, j
    return ba, bi, bj, best / max(1, n)


def correlative_search(
    field: np.ndarray,
    origin: tuple[float, float],
    resolution: float,
    points: np.ndarray,
    guess: np.ndarray,
    space: float,
    angle: float,
    angle_step: float,
) -> tuple[np.ndarray, float]:
    """The pose within +-`space` m (in steps of one cell) and +-`angle` rad (in steps of
    `angle_step`) of `guess` that puts `points` ((N, 2), base frame) on the highest mean
    of `field`, by brute force (Olson's correlative matching, one resolution). Returns
    (pose, mean field value there)."""
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    g = np.asarray(guess, dtype=np.float64)
    if pts.shape[0] == 0 or field.size == 0:
        return g.copy(), 0.0
    if not (space >= 0 and angle >= 0 and angle_step > 0):
        raise ValueError("correlative search: need space >= 0, angle >= 0, angle_step > 0")
    yaws = g[2] + np.arange(-angle, angle + 1e-9, angle_step)
    steps = max(0, round(space / resolution))
    a, i, j, response = _correlate(
        np.ascontiguousarray(field, dtype=np.float64),
        origin[0],
        origin[1],
        resolution,
        pts,
        float(g[0]),
        float(g[1]),
        yaws,
        steps,
    )
    pose = np.array([g[0] + j * resolution, g[1] + i * resolution, wrap(float(yaws[a]))])
    return pose, float(response)


@dataclass(frozen=True)
class _Solution:
    """What a back-end pass hands to the scan path: the optimised poses `after` of the
    first len(after) nodes, the poses `before` they had when the pass began, and the map
    rebuilt from `after` (None when no scan moved enough to matter)."""

    before: np.ndarray
    after: np.ndarray
    grid: LogOddsGrid | None


class PoseGraphSlam:
    """Feed scans with `process`; read `pose`, `grid`, `trajectory` and `closures`.

    The scan path (`process`) matches every scan against the current map and adds the
    nodes. The back end (loop-closure searches, the optimisation and the map rebuild)
    runs in one worker thread when `params.background` (its heavy parts, the compiled
    correlative search and the sparse solve, release the GIL), otherwise inline. Its
    result is swapped in at the start of the next `process`: the optimised poses, the
    nodes added meanwhile carried along with the last optimised one, and the rebuilt map
    with their scans written in. `settle` waits for the back end and optimises what is
    still pending; `close` stops the worker."""

    uses_odometry = False

    def __init__(self, params: PoseGraphParams | None = None) -> None:
        self.params = p = params or PoseGraphParams()
        self._model = LogOddsModel.from_probabilities(0.4, 0.9)
        self._grid = LogOddsGrid(p.resolution, model=self._model)
        self._pyramid: list[np.ndarray] | None = None
        self.matcher = ScanMatcher(p.match_levels, p.iterations)
        self.pose = np.zeros(3)
        self.nodes: list[np.ndarray] = []
        self.scans: list[Beams] = []
        self.edges: list[Edge] = []
        self.closures = 0
        self.loop_attempts = 0
        self.optimizations = 0
        self.rebuilds = 0
        self._written: list[np.ndarray] = []
        self.optimize_time = 0.0
        self.backend_time = 0.0
        self.map_updates = 0
        self._pending = 0
        self._last_closure = -1 << 30
        self._last_hessian = np.eye(3)
        self.stamps: list[float] = []
        # Every scan's pose as (node index, pose relative to that node).
        self._anchors: list[int] = []
        self._offsets: list[np.ndarray] = []
        # Shared with the back end: nodes, scans and edges grow under the lock; `_queue`
        # holds the nodes still to be searched for a loop; `_solution` waits to be
        # swapped in. A pass is only started when none runs and no solution waits, so
        # the first len(solution.after) nodes do not move while a pass runs.
        self._lock = threading.Lock()
        self._queue: list[int] = []
        self._solution: _Solution | None = None
        self._job: Future[None] | None = None
        self._executor: ThreadPoolExecutor | None = None

    @property
    def usable_range(self) -> float:
        return self.params.max_laser_range

    @property
    def min_range(self) -> float:
        return self.params.laser_min_dist

    @property
    def grid(self) -> LogOddsGrid:
        """The current map: from the optimised poses of the last back-end pass swapped
        in, plus the scans added since (call `settle` first for the final map)."""
        return self._grid

    @property
    def busy(self) -> bool:
        """Whether a back-end pass is running in the worker now."""
        return self._job is not None and not self._job.done()

    def process(self, scan: Beams, stamp: float, odom: np.ndarray | None = None) -> np.ndarray:
        """Match one scan (odometry, if given, is ignored), add a node when the robot has
        moved enough and hand it to the back end; return the pose (x, y, yaw)."""
        if not self.params.lockstep:
            self._adopt()
        if self.nodes and scan.hit.any():
            res = self.matcher.match(self._grid, scan.hits, self.pose, self._pyramid)
            self.pose, self._last_hessian = res.pose, res.hessian
        if self._moved_enough():
            self._add_node(scan)
        self.stamps.append(float(stamp))
        self._anchors.append(len(self.nodes) - 1)
        self._offsets.append(relative(self.nodes[-1], self.pose))
        return self.pose.copy()

    def _moved_enough(self) -> bool:
        if not self.nodes:
            return True
        d = relative(self.nodes[-1], self.pose)
        p = self.params
        return bool(
            np.hypot(d[0], d[1]) >= p.minimum_travel_distance
            or abs(d[2]) >= p.minimum_travel_heading
        )

    def _edge_info(self, hessian: np.ndarray, frame_yaw: float) -> np.ndarray:
        # The match's Hessian is over the world pose; the edge is in node i's frame.
        c, s = np.cos(frame_yaw), np.sin(frame_yaw)
        rot = np.eye(3)
        rot[:2, :2] = [[c, -s], [s, c]]
        h = rot.T @ hessian @ rot
        h = 0.5 * (h + h.T)
        # A floor so that a direction the scan cannot see still has some stiffness.
        return h + np.diag([1e2, 1e2, 1e2])

    def _add_node(self, scan: Beams) -> None:
        if self.params.lockstep and self._job is not None:
            job, self._job = self._job, None
            job.result()
            self._adopt()
        k = len(self.nodes)
        with self._lock:
            self.nodes.append(self.pose.copy())
            self.scans.append(scan)
            self._written.append(self.pose.copy())
            if k > 0:
                prev = self.nodes[k - 1]
                self.edges.append(
                    Edge(
                        k - 1,
                        k,
                        relative(prev, self.pose),
                        self._edge_info(self._last_hessian, prev[2]),
                    )
                )
                self._queue.append(k)
        self._write(self._grid, self.pose, scan)
        self._pyramid = self._grid.pyramid(self.params.match_levels)
        self.map_updates += 1
        if k > 0:
            self._start_pass()

    def _start_pass(self, flush: bool = False) -> None:
        """Run a back-end pass (in the worker, or here) if there is work and none runs."""
        if self._job is not None and self._job.done():
            job, self._job = self._job, None
            job.result()  # a failure in the back end surfaces here, on the scan path
        if self.busy or self._solution is not None:
            return
        if not self._queue and not (flush and self._pending):
            return
        # the pass's input is taken here, on the scan path: what it sees does not
        # depend on when the worker starts
        with self._lock:
            todo, self._queue = self._queue, []
            nodes = np.array(self.nodes)
            scans = self.scans[: len(nodes)]
        if not self.params.background:
            self._backend_pass(flush, todo, nodes, scans)
            self._adopt()
            return
        if self._executor is None:
            self._executor = ThreadPoolExecutor(1, thread_name_prefix="posegraph-backend")
        self._job = self._executor.submit(self._backend_pass, flush, todo, nodes, scans)

    @staticmethod
    def _write(grid: LogOddsGrid, pose: np.ndarray, scan: Beams) -> None:
        origin = transform_points(pose, np.array([scan.origin]))[0]
        grid.integrate(origin, transform_points(pose, scan.ends), scan.hit)

    def _backend_pass(
        self, flush: bool, todo: list[int], nodes: np.ndarray, scans: list[Beams]
    ) -> None:
        """Search the nodes `todo` for loop closures; after `optimize_every` accepted
        closures (or any, when `flush`), optimise the graph and rebuild the map, and
        leave the result in `_solution`. Runs in the worker on a snapshot of the nodes
        and their scans; touches no state of the scan path but the shared lists (under
        the lock)."""
        t0 = time.perf_counter()
        found = [e for e in (self._close_loop(k, nodes, scans) for k in todo) if e is not None]
        with self._lock:
            self.edges.extend(found)
        self._pending += len(found)
        if self._pending and (self._pending >= self.params.optimize_every or flush):
            self._solution = self._optimise(nodes, scans)
        self.backend_time += time.perf_counter() - t0

    def _close_loop(self, k: int, nodes: np.ndarray, scans: list[Beams]) -> Edge | None:
        """A loop-closure edge from node k to an earlier node near it, or None."""
        p = self.params
        if k <= p.loop_min_chain or k - self._last_closure <= p.loop_cooldown:
            return None
        here = nodes[k]
        old = nodes[: k - p.loop_min_chain + 1]
        d = np.hypot(old[:, 0] - here[0], old[:, 1] - here[1])
        cand = int(np.argmin(d))
        if d[cand] > p.loop_search_maximum_distance:
            return None
        self.loop_attempts += 1
        local = LogOddsGrid(p.resolution, model=self._model)
        lo, hi = (
            max(0, cand - p.loop_neighbours),
            min(k - p.loop_min_chain, cand + p.loop_neighbours),
        )
        for n in range(lo, hi + 1):
            self._write(local, nodes[n], scans[n])
        hits = scans[k].hits
        if hits.shape[0] < 20:
            return None
        sub = hits[:: max(1, hits.shape[0] // p.loop_points)]
        field = likelihood_field(local, 2 * p.resolution)
        found, response = correlative_search(
            field,
            local.origin,
            local.resolution,
            sub,
            here,
            p.loop_search_space,
            p.loop_search_angle,
            p.loop_search_angle_step,
        )
        if response < p.loop_match_minimum_response:
            return None
        fine = self.matcher.match(local, hits, found)
        # Consistency: the Gauss-Newton refinement stays by the search's peak.
        shift = relative(found, fine.pose)
        if np.hypot(shift[0], shift[1]) > 2 * p.resolution or abs(shift[2]) > 0.02:
            return None
        anchor = nodes[cand]
        self.closures += 1
        self._last_closure = k
        return Edge(
            cand, k, relative(anchor, fine.pose), self._edge_info(fine.hessian, anchor[2]), True
        )

    def _optimise(self, nodes: np.ndarray, scans: list[Beams]) -> _Solution:
        """Optimise the graph over `nodes` (a snapshot) and rebuild the map from them
        when some scan would land elsewhere by more than `map_rebuild_shift` (a turn
        counts at 5 m, the length of a typical beam)."""
        t0 = time.perf_counter()
        n = len(nodes)
        with self._lock:
            edges = [e for e in self.edges if e.i < n and e.j < n]
            written = np.array(self._written[:n])
        after, _, _ = optimize_graph(nodes, edges)
        turn = np.abs((after[:, 2] - written[:, 2] + np.pi) % (2 * np.pi) - np.pi)
        shift = np.hypot(*(after[:, :2] - written[:, :2]).T) + 5.0 * turn
        grid = None
        if shift.max() > self.params.map_rebuild_shift:
            grid = LogOddsGrid(self.params.resolution, model=self._model)
            for q, s in zip(after, scans, strict=True):
                self._write(grid, q, s)
        self._pending = 0
        self.optimizations += 1
        self.optimize_time += time.perf_counter() - t0
        return _Solution(nodes, after, grid)

    def _adopt(self) -> None:
        """Swap in a finished back-end pass: the optimised nodes, the nodes added since
        moved with the last optimised one, the current pose likewise, and the rebuilt
        map with the newer nodes' scans written in."""
        sol = self._solution
        if sol is None:
            return
        n = len(sol.after)

        def carried(q: np.ndarray) -> np.ndarray:
            return compose(sol.after[-1], relative(sol.before[-1], q))

        with self._lock:
            newer = [carried(q) for q in self.nodes[n:]]
            self.nodes = [q.copy() for q in sol.after] + newer
        self.pose = carried(self.pose)
        if sol.grid is not None:
            for q, s in zip(newer, self.scans[n:], strict=True):
                self._write(sol.grid, q, s)
            self._grid = sol.grid
            self._pyramid = sol.grid.pyramid(self.params.match_levels)
            with self._lock:
                self._written = [q.copy() for q in self.nodes]
            self.rebuilds += 1
        self._solution = None
        # Nodes queued while the pass ran wait for the next one.
        self._start_pass()

    def settle(self) -> None:
        """Wait for the back end, search what is queued, optimise the closures still
        pending and swap the result in: afterwards `grid` and `trajectory` are final."""
        while True:
            if self._job is not None:
                self._job.result()
                self._job = None
            self._adopt()
            self._start_pass(flush=True)
            if self._job is None and self._solution is None:
                return

    def close(self) -> None:
        """Stop the worker thread (after the pass it runs, if any)."""
        if self._executor is not None:
            self._executor.shutdown(wait=True)
            self._executor = None
            self._job = None

    def map_to_odom(self, odom: np.ndarray) -> np.ndarray:
        """The map -> odom transform that puts `odom` (the odometry pose now) at the
        estimated pose."""
        return compose(self.pose, relative(odom, np.zeros(3)))

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (N,), poses (N, 3)) of every scan processed, moved with the optimised
        nodes they hang from."""
        poses = [
            compose(self.nodes[a], o) for a, o in zip(self._anchors, self._offsets, strict=True)
        ]
        return np.asarray(self.stamps), np.asarray(poses).reshape(-1, 3)
