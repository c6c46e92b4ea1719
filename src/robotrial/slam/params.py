"""SLAM parameters with the names and defaults of the ROS packages (layer 3).

`GMappingParams` follows slam_gmapping's ROS parameters, `HectorParams` hector_mapping's,
so a ROS user's launch-file values carry over (`from_dict` takes them by name).
Where a ROS default assumes a real robot and a huge map (xmin = -100 m), ours grows the
map as the robot explores instead, so there is no size parameter.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any, TypeVar

T = TypeVar("T")


def _from_dict(cls: type[T], values: dict[str, Any] | None) -> T:
    known = {f.name: f for f in fields(cls)}  # type: ignore[arg-type]
    out = cls()
    for k, v in (values or {}).items():
        if k not in known:
            raise ValueError(f"{cls.__name__}: unknown parameter {k!r}; known: {sorted(known)}")
        kind = type(getattr(out, k))
        if kind is bool and not isinstance(v, bool):
            # bool("false") is True: accept only what reads as a truth value.
            words = {"true": True, "1": True, "false": False, "0": False}
            if str(v).lower() not in words:
                raise ValueError(f"{cls.__name__}: parameter {k!r}={v!r}: expected true or false")
            v = words[str(v).lower()]
        try:
            out = replace(out, **{k: kind(v)})  # type: ignore[type-var]
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{cls.__name__}: parameter {k!r}={v!r}: {exc}") from exc
    return out


@dataclass(frozen=True)
class GMappingParams:
    """slam_gmapping parameters (ROS names and defaults). Distances in m, angles in rad,
    times in s; srr/srt/str/stt are the odometry error model (translation from
    translation, translation from rotation, rotation from translation, rotation from
    rotation)."""

    particles: int = 30
    delta: float = 0.05
    linearUpdate: float = 1.0
    angularUpdate: float = 0.5
    temporalUpdate: float = -1.0
    map_update_interval: float = 5.0
    # 0: as slam_gmapping when the parameter is not set (maxRange = the scanner's
    # range_max - 0.01, maxUrange = maxRange; see GMappingSlam.range_limits).
    maxUrange: float = 0.0
    maxRange: float = 0.0
    sigma: float = 0.05
    kernelSize: int = 1
    lstep: float = 0.05
    astep: float = 0.05
    iterations: int = 5
    lsigma: float = 0.075
    ogain: float = 3.0
    lskip: int = 0
    minimumScore: float = 0.0
    srr: float = 0.1
    srt: float = 0.2
    str: float = 0.1
    stt: float = 0.2
    resampleThreshold: float = 0.5
    occ_thresh: float = 0.25
    # Multi-resolution levels of the Gauss-Newton matcher that improves each particle's
    # proposal (GMapping hill-climbs in steps of lstep/astep instead).
    match_levels: int = 3
    seed: int = 0

    def __post_init__(self) -> None:
        if self.particles < 1:
            raise ValueError(f"gmapping: particles must be >= 1, got {self.particles}")
        if not self.delta > 0:
            raise ValueError(f"gmapping: delta (map resolution) must be > 0, got {self.delta}")
        if not 0 < self.resampleThreshold <= 1:
            raise ValueError(
                f"gmapping: resampleThreshold must be in (0, 1], got {self.resampleThreshold}"
            )
        if self.linearUpdate < 0 or self.angularUpdate < 0:
            raise ValueError("gmapping: linearUpdate and angularUpdate must be >= 0")
        if self.maxUrange < 0 or self.maxRange < 0:
            raise ValueError(
                f"gmapping: maxUrange and maxRange must be > 0 (or 0: from the scanner), "
                f"got {self.maxUrange}, {self.maxRange}"
            )

    @staticmethod
    def from_dict(values: dict[str, Any] | None) -> GMappingParams:
        return _from_dict(GMappingParams, values)


@dataclass(frozen=True)
class OdometryModel:
    """The odometry motion model of Hector's and the pose graph's front ends: standard
    deviations of x, y and yaw per m and rad moved (`slam.scan.motion_sigma`), at least
    the minimums."""

    odom_trans_per_trans: float = 0.1
    odom_trans_per_rot: float = 0.05
    odom_rot_per_trans: float = 0.05
    odom_rot_per_rot: float = 0.1
    odom_min_sigma_xy: float = 0.005
    odom_min_sigma_yaw: float = 0.005


@dataclass(frozen=True)
class HectorParams(OdometryModel):
    """hector_mapping parameters (ROS names and defaults)."""

    map_resolution: float = 0.025
    map_multi_res_levels: int = 3
    update_factor_free: float = 0.4
    update_factor_occupied: float = 0.9
    map_update_distance_thresh: float = 0.4
    map_update_angle_thresh: float = 0.9
    laser_min_dist: float = 0.4
    laser_max_dist: float = 30.0
    map_pub_period: float = 2.0
    # Gauss-Newton steps per resolution level (hector_mapping hard-codes a few).
    iterations: int = 5
    # Odometry, when given: the start of each match and its prior (OdometryModel).
    use_odometry: bool = True

    def __post_init__(self) -> None:
        if not self.map_resolution > 0:
            raise ValueError(f"hector: map_resolution must be > 0, got {self.map_resolution}")
        if self.map_multi_res_levels < 1:
            raise ValueError("hector: map_multi_res_levels must be >= 1")
        if not self.laser_max_dist > self.laser_min_dist >= 0:
            raise ValueError("hector: need 0 <= laser_min_dist < laser_max_dist")

    @staticmethod
    def from_dict(values: dict[str, Any] | None) -> HectorParams:
        return _from_dict(HectorParams, values)


@dataclass(frozen=True)
class PoseGraphParams(OdometryModel):
    """Pose-graph SLAM parameters (names after slam_toolbox's where one exists; see
    slam/posegraph.py for what each part does). Distances in m, angles in rad.

    Nodes: one every `minimum_travel_distance` or `minimum_travel_heading`. Front end:
    scans are matched against the last `scan_buffer_size` nodes' scans within
    `scan_buffer_maximum_scan_distance` m of path, from the odometry's prediction, over a
    window of 3 standard deviations of the odometry motion model (`odom_*`: standard
    deviation per m or rad moved, plus, in heading, the turn made in `odom_time_sigma` s
    at the rate the robot turned, for an odometry pose not taken at the scan's instant;
    at least `odom_min_sigma_*`), at most
    +-`correlation_search_space` m and +-`correlation_search_angle` rad (the whole window
    without odometry); the search is skipped when the window lies within Gauss-Newton's
    reach (its coarsest cell, `gauss_newton_reach_angle`). A match's covariance is its
    Hessian's inverse times its mean squared residual times `match_variance_scale`, at
    least `match_min_sigma_*`.
    Loop closure: candidates at least `loop_min_chain` nodes back whose estimate lies
    within `loop_search_maximum_distance` plus the search window of the new node; the
    window is +-(`loop_search_space` + `loop_search_growth` * graph distance) m, at most
    `loop_search_space_max`, and likewise for the angle, on a likelihood field of
    `loop_resolution` m cells; a match is kept when its mean field value reaches
    `loop_match_minimum_response` and a closure from a node at most `loop_confirm_nodes`
    away implies the same correction, within 3 standard deviations of both closures'
    covariances plus `loop_confirm_distance` m (and 2 % of the way between the nodes) and
    `loop_confirm_angle` rad. Its covariance is open along a corridor longer than the
    window, long towards other places the scan fits nearly as well, and otherwise the
    fine search's spread plus the refinement's (tight across a corridor), at least
    `loop_min_sigma_*`. In the graph, loop closures carry a Cauchy kernel
    `loop_kernel_width` standard deviations wide; after an optimisation the worst
    closure with a chi-square above `loop_max_chi2` is taken out and the graph optimised
    again, `loop_removal_rounds` times at most. The
    graph is optimised when a closure waiting in it has a chi-square above
    `loop_optimize_chi2` at the current estimate, or after `optimize_every` closures.
    With `background` the loop searches and the optimisation run in a worker thread, off
    the scan path (False: inline, for comparisons). A pass is swapped in at the first scan
    after it ends, which depends on the timing; with `lockstep`, when the next node is
    added, the scan path waiting for it then if it has not finished: the same scans give
    the same map whatever the machine's load; a log replay (`robotrial slam --log`,
    `bench slam --real`) sets it, a live robot does not. Without it, when `backend_max_backlog`
    nodes wait for the worker, the scan path waits for the pass it runs: a log replayed
    far faster than it was taken (MIT Killian Court: 300 times) would otherwise leave the
    loop searches hundreds of nodes behind, made on estimates no closure has corrected
    yet, and the result would hang on the load; a robot whose back end keeps up never
    waits. `map_rebuild_shift`: a pass that moves a node by less (a turn counting at 5
    m) leaves the maps as they are."""

    resolution: float = 0.025
    match_levels: int = 4
    iterations: int = 5
    minimum_travel_distance: float = 0.3
    minimum_travel_heading: float = 0.349
    laser_min_dist: float = 0.4
    max_laser_range: float = 30.0
    scan_buffer_size: int = 30
    scan_buffer_maximum_scan_distance: float = 10.0
    correlation_search_space: float = 0.5
    correlation_search_angle: float = 0.35
    correlation_points: int = 150
    gauss_newton_reach_angle: float = 0.1
    odom_time_sigma: float = 0.0
    match_variance_scale: float = 30.0
    match_min_sigma_xy: float = 0.005
    match_min_sigma_yaw: float = 0.002
    loop_search_maximum_distance: float = 2.0
    loop_min_chain: int = 10
    loop_neighbours: int = 3
    loop_search_space: float = 0.3
    loop_search_growth: float = 0.05
    loop_search_space_max: float = 10.0
    loop_search_angle: float = 0.15
    loop_search_angle_growth: float = 0.005
    loop_search_angle_max: float = 0.35
    loop_search_angle_step: float = 0.005
    loop_cooldown: int = 1
    loop_match_minimum_response: float = 0.6
    loop_points: int = 300
    loop_resolution: float = 0.05
    loop_confirm_nodes: int = 10
    loop_confirm_distance: float = 0.1
    loop_confirm_angle: float = 0.05
    loop_min_sigma_xy: float = 0.02
    loop_min_sigma_yaw: float = 0.01
    loop_kernel_width: float = 3.0
    loop_max_chi2: float = 25.0
    loop_removal_rounds: int = 3
    loop_optimize_chi2: float = 9.0
    optimize_every: int = 8
    map_rebuild_shift: float = 0.01
    map_pub_period: float = 2.0
    background: bool = True
    lockstep: bool = False
    backend_max_backlog: int = 5

    def __post_init__(self) -> None:
        if self.backend_max_backlog < 1:
            raise ValueError(
                f"graph: backend_max_backlog must be >= 1, got {self.backend_max_backlog}"
            )
        if not self.resolution > 0:
            raise ValueError(f"graph: resolution must be > 0, got {self.resolution}")
        if self.match_levels < 1 or self.iterations < 1:
            raise ValueError("graph: match_levels and iterations must be >= 1")
        if not self.max_laser_range > self.laser_min_dist >= 0:
            raise ValueError("graph: need 0 <= laser_min_dist < max_laser_range")
        if self.minimum_travel_distance <= 0 or self.minimum_travel_heading <= 0:
            raise ValueError("graph: minimum_travel_distance and _heading must be > 0")
        if self.loop_min_chain < 1 or self.loop_neighbours < 0 or self.optimize_every < 1:
            raise ValueError(
                "graph: loop_min_chain and optimize_every must be >= 1, loop_neighbours >= 0"
            )
        if not 0 < self.loop_match_minimum_response <= 1:
            raise ValueError("graph: loop_match_minimum_response must be in (0, 1]")
        if self.scan_buffer_size < 1 or self.correlation_points < 1:
            raise ValueError("graph: scan_buffer_size and correlation_points must be >= 1")
        if not (self.loop_search_space_max >= self.loop_search_space > 0):
            raise ValueError("graph: need 0 < loop_search_space <= loop_search_space_max")
        sigmas = (
            self.match_min_sigma_xy,
            self.match_min_sigma_yaw,
            self.odom_min_sigma_xy,
            self.odom_min_sigma_yaw,
            self.loop_min_sigma_xy,
            self.loop_min_sigma_yaw,
        )
        if min(sigmas) <= 0:
            raise ValueError("graph: the *_min_sigma_* parameters must be > 0")

    @staticmethod
    def from_dict(values: dict[str, Any] | None) -> PoseGraphParams:
        return _from_dict(PoseGraphParams, values)
