"""GMapping-class SLAM: a Rao-Blackwellized particle filter over odometry and scans
(layer 3).

Each particle carries a pose, a log-weight and its own map. When the robot has moved
`linearUpdate` or turned `angularUpdate` (odometry) since the last update:

1. every particle draws its new pose from the odometry motion model (srr, srt, str, stt);
2. the scan matcher moves that draw to where the scan fits the particle's own map, with
   the motion model (centred on the odometry's prediction, not on the draw) as a prior
   (the improved proposal of Grisetti et al. 2007); a match
   scoring below `minimumScore` is not trusted and the draw stays. The weights use one
   scan end point per map cell, the fine level of the match every second of those, the
   coarse levels the best particle's map (computed once an update);
3. the particle's weight grows by the scan's likelihood on its map (likelihood field,
   `lsigma`, `kernelSize`), tempered by `ogain`;
4. every particle writes the scan into its map at its new pose (a thinned beam fan);
5. when the effective sample size falls below `resampleThreshold` * particles, the
   particles are resampled (systematic), children taking their parent's map.

The maps share their tiles until a particle writes into one (`tiled.TiledMaps`, as
GMapping's patches): a child holds its parent's tiles, and each update copies only the
tiles the scan crosses. Steps 2-4 for all particles are one compiled call
(`TiledMaps.match`). Writing before resampling gives the maps GMapping gets by
resampling first, as a child takes its parent's pose and map.

Between updates the pose follows odometry from the best particle. The trajectory at the
end is the best particle's ancestry, so it is consistent with its map.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.params import GMappingParams
from robotrial.slam.scan import Beams, compose, motion_sigma, relative
from robotrial.slam.tiled import TiledMaps, landing_box


def one_per_cell(points: np.ndarray, cell: float) -> np.ndarray:
    """The first of the points that fall in each cell of a `cell`-sized grid: a dense
    scan puts several end points in one map cell, and they constrain the match alike."""
    keys = np.floor(points / cell).astype(np.int64)
    _, first = np.unique(keys[:, 0] * 2_000_003 + keys[:, 1], return_index=True)
    return points[np.sort(first)]


def compose_many(poses: np.ndarray, deltas: np.ndarray) -> np.ndarray:
    """Row-wise `compose` of (N, 3) poses with (N, 3) relative motions."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    out = np.empty_like(poses, dtype=np.float64)
    out[:, 0] = poses[:, 0] + c * deltas[:, 0] - s * deltas[:, 1]
    out[:, 1] = poses[:, 1] + s * deltas[:, 0] + c * deltas[:, 1]
    out[:, 2] = (poses[:, 2] + deltas[:, 2] + np.pi) % (2 * np.pi) - np.pi
    return out


def angle_step(scan: Beams) -> float | None:
    """The angle between neighbouring beams: the scan's own, else the median seen from
    the laser (None for fewer than two beams)."""
    if scan.angle_step is not None and scan.angle_step > 0:
        return scan.angle_step
    if scan.ends.shape[0] < 2:
        return None
    a = np.unwrap(np.arctan2(scan.ends[:, 1] - scan.origin[1], scan.ends[:, 0] - scan.origin[0]))
    step = float(np.median(np.abs(np.diff(a))))
    return step if step > 0 else None


# slam_gmapping's documented maxUrange, for a scanner that states no range_max.
DEFAULT_USABLE_RANGE = 80.0


class OdometryRequired(ValueError):
    """GMapping was given a scan without an odometry pose."""


@dataclass
class _Step:
    poses: np.ndarray  # (N, 3) particle poses after this update
    parents: np.ndarray  # (N,) index of each particle's parent at the previous update


class GMappingSlam:
    """Feed scans with odometry through `process`; read `pose`, `grid`, `trajectory`."""

    uses_odometry = True

    def __init__(self, params: GMappingParams | None = None) -> None:
        self.params = p = params or GMappingParams()
        self.rng = np.random.default_rng(p.seed)
        n = p.particles
        self.poses = np.zeros((n, 3))
        self.logw = np.zeros(n)
        self.maps = TiledMaps(n, p.delta)
        self._odom_at_update: np.ndarray | None = None
        self._best = 0
        self.history: list[_Step] = []
        self._scans: list[tuple[float, int, np.ndarray]] = []
        self.updates = 0
        self.resamples = 0
        self.neff = float(n)

    def range_limits(self, range_max: float) -> tuple[float, float, float]:
        """(min, maximum, usable) range for a scanner whose range_max is given (0 when
        unknown), as slam_gmapping sets them: maxRange unset is range_max - 0.01 (so a
        reading at range_max, "no return", is left out), maxUrange unset is maxRange."""
        p = self.params
        top = p.maxRange if p.maxRange > 0 else (range_max - 0.01 if range_max > 0 else np.inf)
        usable = p.maxUrange if p.maxUrange > 0 else top
        if not np.isfinite(usable):
            usable = DEFAULT_USABLE_RANGE
        return 0.0, top, min(usable, top)

    @property
    def grid(self) -> LogOddsGrid:
        """The best particle's map."""
        return self.maps.dense(self._best)

    @property
    def map_bytes(self) -> int:
        """The memory the particles' maps take (their tiles held once, and indexes)."""
        return self.maps.nbytes

    @property
    def pose(self) -> np.ndarray:
        return self.poses[self._best].copy()

    def process(self, scan: Beams, stamp: float, odom: np.ndarray | None = None) -> np.ndarray:
        """Take one scan with the odometry pose (x, y, yaw in the odom frame) at its time;
        returns the base's pose in the map frame (the best particle's)."""
        if odom is None:
            raise OdometryRequired(
                "gmapping needs odometry with every scan (a /odom topic or odom -> base TF); "
                "use the hector method for scans alone"
            )
        odom = np.asarray(odom, dtype=np.float64)
        p = self.params
        if self._odom_at_update is None:
            self._register(scan)
            self._odom_at_update = odom.copy()
            self.history.append(_Step(self.poses.copy(), np.arange(p.particles)))
            self.updates += 1
        else:
            d = relative(self._odom_at_update, odom)
            moved = np.hypot(d[0], d[1]) >= p.linearUpdate or abs(d[2]) >= p.angularUpdate
            if moved and scan.hit.any():
                self._update(scan, d)
                self._odom_at_update = odom.copy()
        delta = relative(self._odom_at_update, odom)
        self._scans.append((float(stamp), len(self.history) - 1, delta))
        return compose(self.poses[self._best], delta)

    def _update(self, scan: Beams, d: np.ndarray) -> None:
        p = self.params
        n = p.particles
        hits = one_per_cell(scan.hits, p.delta)
        stride = p.lskip + 1
        sx, sy, sth = self._motion_sigma(d)
        sigma = (max(sx, sy), max(sx, sy), sth)  # isotropic: the map frame is rotated
        noise = self.rng.normal(size=(n, 3)) * np.asarray(self._motion_sigma(d))
        moved = np.broadcast_to(np.asarray(d, dtype=np.float64), (n, 3))
        guesses = compose_many(self.poses, moved + noise)
        # The match starts from the draw but its motion prior is centred on the odometry's
        # prediction: centred on the draw, the prior would hold each particle at its own
        # noise, which then adds up over the updates (the proposal is the product of the
        # scan's likelihood and the motion model, whose mean is the prediction).
        predicted = compose_many(self.poses, moved)
        step = angle_step(scan)
        fan = replace(scan, angle_step=step) if step is not None else None
        # The coarse levels of the best particle's map, where the scan's end points can
        # land from any particle's guess (and a metre and two coarse cells around), steer
        # every particle's match.
        box = landing_box(hits, guesses, 1.0 + p.delta * (1 << p.match_levels))
        coarse, origin = self.maps.coarse(self._best, box, p.match_levels)
        self.poses, loglik = self.maps.match(
            coarse,
            origin,
            hits[:: 2 * stride],
            hits,
            guesses,
            sigma,
            iterations=p.iterations,
            stride=stride,
            kernel=p.kernelSize,
            sigma=p.sigma,
            lsigma=p.lsigma,
            min_score=p.minimumScore,
            scan=fan,
            prior_means=predicted,
        )
        self.logw += loglik
        gain = 1.0 / (p.ogain * n)
        w = np.exp(gain * (self.logw - self.logw.max()))
        w /= w.sum()
        self.neff = float(1.0 / np.sum(w * w))
        self._best = int(np.argmax(w))
        parents = np.arange(n)
        if self.neff < p.resampleThreshold * n:
            parents = self._systematic(w)
            self.poses = self.poses[parents].copy()
            self.logw[:] = 0.0
            self.maps.resample(parents)
            self._best = int(np.argmax(w[parents]))
            self.resamples += 1
        self.history.append(_Step(self.poses.copy(), parents))
        self.updates += 1

    def _motion_sigma(self, d: np.ndarray) -> tuple[float, float, float]:
        """GMapping's odometry motion model: standard deviations of x, y (in the frame
        of the previous pose) and yaw, growing with the distance and angle moved."""
        p = self.params
        return motion_sigma(d, p.srr, p.str, p.srt, p.stt)

    def _systematic(self, w: np.ndarray) -> np.ndarray:
        n = w.size
        positions = (self.rng.random() + np.arange(n)) / n
        idx = np.searchsorted(np.cumsum(w), positions)
        return np.minimum(idx, n - 1)

    def _register(self, scan: Beams) -> None:
        step = angle_step(scan)
        if step is None:
            return
        self.maps.write(self.poses, replace(scan, angle_step=step))

    def map_to_odom(self, odom: np.ndarray) -> np.ndarray:
        """The map -> odom transform that puts `odom` (the odometry pose now) at the
        estimated pose."""
        est = compose(self.poses[self._best], relative(self._odom_at_update, odom))
        return compose(est, relative(odom, np.zeros(3)))

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps, poses (N, 3)) of every scan: the best particle's ancestry at each
        update, carried forward by odometry between updates."""
        if not self._scans:
            return np.zeros(0), np.zeros((0, 3))
        lineage = np.zeros((len(self.history), 3))
        idx = self._best
        for k in range(len(self.history) - 1, -1, -1):
            lineage[k] = self.history[k].poses[idx]
            idx = int(self.history[k].parents[idx])
        stamps = np.array([s for s, _, _ in self._scans])
        poses = np.array([compose(lineage[k], d) for _, k, d in self._scans])
        return stamps, poses
