"""SLAM over real-robot CARMEN logs: a log as a Recording, the relation scores of a run,
and where the public logs are looked for (layer 5).

The public data sets (Intel Research Lab, ACES, Freiburg 079) come with relation files
(Kuemmerle et al. 2009): the relative pose between chosen pairs of scans, found by hand-
checked matching. A run is scored by how well its relative motions agree with them
(`robotrial.slam.metrics.relation_metric`). The logs are never part of the repository:
they are looked for in a cache folder (`cache_dir`), where a user puts them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from robotrial.cache import cache_dir as shared_cache
from robotrial.model.carmen import CarmenLog, read_carmen, read_relations
from robotrial.slam.metrics import relation_metric
from robotrial.slam.scan import compose, relative
from robotrial.trials.slam import Recording, ScanSample, SlamRun


def recording_from_log(log: CarmenLog) -> Recording:
    """What the SLAM runner takes, from a CARMEN log: its scans in the log's order with
    the odometry pose of each; no ground truth (real logs have none), the laser 0.3 m
    above the floor (unused by SLAM)."""
    scans = [
        ScanSample(s.stamp, s.ranges, s.angle_min, s.angle_increment, 0.0, s.range_max)
        for s in log.scans
    ]
    return Recording(
        scans,
        log.odom,
        np.zeros((0, 4)),
        log.laser_pose,
        0.3,
        log.source,
        log.scan_odometry(),
    )


# GMapping's odometry error model (srr, srt, str, stt: m per m, m per rad, rad per m, rad
# per rad) for a log whose odometry is an already corrected trajectory: about 1 mm per m.
# Its defaults (0.1-0.2) are for raw wheel odometry; drawn around a trajectory that is
# already right, that noise bends each particle off it by about 0.03 rad per 20 m, and
# the scan match pulls it only part of the way back (docs/benchmarks/slam.md).
CORRECTED_MOTION = {"srr": 0.001, "srt": 0.001, "str": 0.001, "stt": 0.001}
# The pose graph's odometry model (the same four ratios, as its odometry edges' standard
# deviations) for such a log: with the raw-odometry defaults (0.05-0.1) the odometry edges
# weigh too little against the scan matches and the loop closures, most of which the
# correlative search leaves open along a corridor (docs/benchmarks/slam.md).
CORRECTED_GRAPH_MOTION = {
    "odom_trans_per_trans": 0.001,
    "odom_trans_per_rot": 0.001,
    "odom_rot_per_trans": 0.001,
    "odom_rot_per_rot": 0.001,
}
# The pose graph's timing uncertainty of odometry poses (s) for a log whose poses are not
# all taken at their scans' instants: MIT CSAIL's turn 0.2-0.4 rad off, about a scan
# period of a fast turn, now and then.
TIMING = {"odom_time_sigma": 0.2}


def declared_params(log: CarmenLog, method: str) -> tuple[dict[str, float], str]:
    """Parameters a log's reader sets for a method because of what the log is, and why
    (a user's own parameters override them): GMapping's motion model for a corrected
    trajectory (`CarmenLog.corrected_odometry`) and the pose graph's likewise, the pose
    graph's timing uncertainty for odometry poses off their scans' instants
    (`CarmenLog.odometry_timing`)."""
    if method == "gmapping" and log.corrected_odometry:
        return dict(CORRECTED_MOTION), log.corrected_odometry
    if method == "graph" and log.corrected_odometry:
        return dict(CORRECTED_GRAPH_MOTION), log.corrected_odometry
    if method == "graph" and log.odometry_timing:
        return dict(TIMING), log.odometry_timing
    return {}, ""


def replay_params(method: str) -> dict[str, Any]:
    """Parameters every log replay sets for a method: the pose graph's back end in
    lockstep (each pass swapped in when the next node is added, the scan path waiting
    for it). A log is read far faster than it was taken and its scans do not wait for
    the scheduler: with the threaded back end which nodes each pass sees, and so the
    result, would hang on the machine's load. A user's own parameters override them."""
    return {"lockstep": True} if method == "graph" else {}


@dataclass(frozen=True)
class OdometryDrift:
    """Errors of wheel odometry, to make a raw-odometry log from one whose poses are a
    corrected trajectory: each motion between consecutive scans has its distance scaled
    by 1 + `scale` + N(0, `distance`) and its turn by 1 + N(0, `turn`), and turns
    further by N(0, `heading_noise`) plus `heading_bias` rad per m driven (one wheel a
    little larger than the other). Seeded: the same drift every run."""

    seed: int = 0
    distance: float = 0.05
    turn: float = 0.05
    heading_noise: float = 0.005
    heading_bias: float = 0.002
    scale: float = 0.01


def drift_odometry(log: CarmenLog, drift: OdometryDrift) -> CarmenLog:
    """`log` with its scans' odometry poses replaced by `drift`'s raw-odometry version
    of their consecutive motions (the first pose kept); the log is then no longer
    taken for a corrected trajectory. Relations still score it: they compare relative
    motions of the SLAM estimate, not the odometry."""
    poses = log.scan_odometry()
    if poses is None:
        raise ValueError(f"{log.source or 'log'}: a scan carries no odometry pose to drift")
    rng = np.random.default_rng(drift.seed)
    out = poses.copy()
    for k in range(1, len(poses)):
        d = relative(poses[k - 1], poses[k])
        dist = float(np.hypot(d[0], d[1]))
        factor = 1.0 + drift.scale + rng.normal(0.0, drift.distance)
        turn = d[2] * (1.0 + rng.normal(0.0, drift.turn))
        turn += dist * (drift.heading_bias + rng.normal(0.0, drift.heading_noise))
        out[k] = compose(out[k - 1], (d[0] * factor, d[1] * factor, turn))
    scans = [replace(s, odom=(float(q[0]), float(q[1]), float(q[2])))
             for s, q in zip(log.scans, out, strict=True)]  # fmt: skip
    stamps = np.array([s.stamp for s in log.scans])
    order = np.argsort(stamps, kind="stable")
    odom = np.column_stack([stamps[order], out[order]])
    source = f"{log.source} (odometry drifted, seed {drift.seed})"
    return replace(log, scans=scans, odom=odom, source=source, corrected_odometry="")


def load_log(
    path: str | Path, strict: bool = False, order: str = "file", drift: OdometryDrift | None = None
) -> tuple[Recording, CarmenLog]:
    """A CARMEN log file as a Recording (and the log, for its counts of skipped lines);
    with `drift`, its odometry made raw (`drift_odometry`)."""
    log = read_carmen(path, strict, order)
    if drift is not None:
        log = drift_odometry(log, drift)
    return recording_from_log(log), log


def relation_scores(run: SlamRun, relations_file: str | Path) -> dict[str, float]:
    """The relative-pose error of a run against a relation file."""
    return relation_metric(run.stamps, run.poses, read_relations(relations_file))


def cache_dir() -> Path:
    """Where real logs are kept: the cache's slam-logs folder (robotrial.cache)."""
    return shared_cache("slam-logs")


@dataclass(frozen=True)
class PublicLog:
    """A public data set: the file names looked for in the cache, and the translational
    relation error (mean, std, m) published for it by Kuemmerle et al. (2009), by method."""

    name: str
    title: str
    log_names: tuple[str, ...]
    relation_names: tuple[str, ...]
    published: dict[str, tuple[float, float]]


# Kuemmerle et al. 2009, their table of absolute translational errors (m, mean ± std)
# for sequential scan matching, a Rao-Blackwellized particle filter (GMapping, 50
# particles) and graph mapping. These figures are as a later survey quotes that table;
# they were not checked against the paper itself (docs/benchmarks/slam.md).
PUBLIC_LOGS: tuple[PublicLog, ...] = (
    PublicLog(
        "intel",
        "Intel Research Lab",
        ("intel.clf", "intel.log", "intel.gfs.log", "intel.clf.gz"),
        ("intel.relations", "intel.relations.txt"),
        {"scan matching": (0.220, 0.296), "RBPF": (0.070, 0.083), "graph mapping": (0.031, 0.026)},
    ),
    PublicLog(
        "aces",
        "ACES building",
        ("aces.clf", "aces.log", "aces.clf.gz"),
        ("aces.relations", "aces.relations.txt"),
        {"scan matching": (0.173, 0.614), "RBPF": (0.060, 0.049), "graph mapping": (0.044, 0.044)},
    ),
    PublicLog(
        "fr079",
        "Freiburg building 079",
        ("fr079.clf", "fr079.log", "fr079-uncorrected.clf", "fr079.clf.gz"),
        ("fr079.relations", "fr079.relations.txt"),
        {"scan matching": (0.258, 0.427), "RBPF": (0.061, 0.044), "graph mapping": (0.056, 0.042)},
    ),
)


def find_public(log: PublicLog, folder: Path | None = None) -> tuple[Path | None, Path | None]:
    """The log and relation files of a public data set in the cache (None when absent)."""
    folder = folder or cache_dir()
    found = [folder / n for n in log.log_names if (folder / n).is_file()]
    rel = [folder / n for n in log.relation_names if (folder / n).is_file()]
    return (found[0] if found else None), (rel[0] if rel else None)


def summary(run: SlamRun, scores: dict[str, Any] | None = None) -> dict[str, Any]:
    """Time per scan (ms, mean and p95), the pose graph's back end (threaded or
    lockstep) and the relation scores of a run."""
    t = run.scan_times
    out: dict[str, Any] = {
        "scans": len(t),
        "time_per_scan_ms": float(t.mean() * 1e3) if len(t) else 0.0,
        "time_per_scan_p95_ms": float(np.percentile(t, 95) * 1e3) if len(t) else 0.0,
    }
    if "lockstep" in run.extra:
        out["back_end"] = "lockstep" if run.extra["lockstep"] else "threaded"
    if scores is not None:
        out["relations"] = scores
    return out
