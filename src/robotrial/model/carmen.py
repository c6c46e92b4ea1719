"""CARMEN robot logs and SLAM relation files, read into and written from arrays (layer 1).

The public 2D laser data sets of the SLAM literature (Intel Research Lab, ACES, Freiburg
079, MIT Killian Court) are CARMEN logs: one message a line, the message type first. A
log is a recording format, so it is read here at the edge, beside the map files; SLAM
(layer 3) only ever sees the arrays. The lines read:

- ``FLASER n r1 .. rn x y theta odom_x odom_y odom_theta timestamp host logger_ts``
  (old style: the laser's pose, then the robot's odometry; the beams are assumed to
  span 180 degrees from -90, as the CARMEN front laser of these logs did);
- ``ROBOTLASER1 type start fov res max_range accuracy remission_mode n r1 .. rn
  m e1 .. em laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
  forward_safety side_safety turn_axis timestamp host logger_ts`` (new style);
- ``RAWLASER1 type start fov res max_range accuracy remission_mode n r1 .. rn m e1 .. em
  timestamp host logger_ts`` (a scan without poses);
- ``ODOM x y theta tv rv accel timestamp host logger_ts``.

Every other message type (PARAM, TRUEPOS, SYNC ...) is passed over and counted. A g2o
file's pose graph (VERTEX_SE2, EDGE_SE2) is read only to say what its laser lines' robot
poses are (`corrected_odometry`): when they are the graph's vertices and already agree
with its loop-closure edges (an edge between vertices more than one apart), they are a
trajectory corrected with those closures, not raw odometry, and a SLAM method's motion
model should say so. The MIT Killian Court log of the rtb-data package is such a file.
Likewise a log whose odometry turns between two scans faster than a base turns has
poses not all taken at their scans' instants (`odometry_timing`; MIT CSAIL's log).
A line of a known type that cannot be read is an error naming the file and the line
(``strict=True``) or is skipped and listed in `CarmenLog.skipped`.

What a reading means depends on the format. A new-style line carries the scanner's
maximum range: a reading at or past it is "no return". An old-style FLASER line carries
none; its scanners (SICK LMS and PLS) measure up to `FLASER_MAX_RANGE` and report "no
return" with a code value above it (81.83 m and 81.91 m are both found in these logs), and
a log whose largest reading recurs far more often than any measured distance could (see
`no_return_code`) uses that value as its code. A reading of 0 or less is no measurement.
No return is stored as inf, no measurement as nan.

Scans stay in the order of the file, which is the order they were taken: some logs'
time stamps step backwards now and then (by up to a second), so sorting them by stamp
would shuffle the robot's path (`order="time"` sorts them all the same). Each laser line
also carries the robot's odometry pose at that scan, kept beside the scan.

A relation file (Kuemmerle et al. 2009, "On measuring the accuracy of SLAM algorithms")
holds one relation a line: ``t1 t2 x y z roll pitch yaw``, the motion of the robot from
its pose at time t1 to its pose at time t2, in the frame of the first.
"""

from __future__ import annotations

import gzip
import io
import math
import zipfile
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# The farthest an old-style (FLASER) reading can be measured: the SICK LMS and PLS of
# these data sets range to 80 m at most and report "no return" with codes above that.
FLASER_MAX_RANGE = 80.0
# A log's largest reading is its "no return" code when at least this share of all its
# readings carry exactly that value (measured distances spread over millimetres).
CODE_SHARE = 1e-3
# The laser lines' robot poses are a corrected trajectory when, as vertices of the file's
# pose graph, they meet its loop-closure edges this well on average (m, rad): raw wheel
# odometry misses a loop closed hundreds of metres later by metres.
CORRECTED_LOOP_TRANS = 0.1
CORRECTED_LOOP_ROT = 0.02
# At least this many loop-closure edges, so that the test means something.
CORRECTED_MIN_LOOPS = 10
# A log whose odometry turns faster than this between two scans (rad/s), at least
# `FAST_TURNS` times, has poses not taken at their scans' instants: wheeled indoor bases
# turn at 1-2 rad/s at most.
FAST_TURN_RATE = 3.0
FAST_TURNS = 3


class CarmenError(ValueError):
    """A line of a CARMEN log or a relation file that cannot be read."""


@dataclass(frozen=True)
class CarmenScan:
    """One laser scan: ranges (m, inf where nothing returned, nan where the scanner
    measured nothing), the angle of the first beam and between beams (rad, in the laser's
    frame), the maximum range (m), and the robot's odometry pose (x, y, yaw) the line
    carried (None for a scan without one)."""

    stamp: float
    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_max: float
    odom: tuple[float, float, float] | None = None


@dataclass
class CarmenLog:
    """Scans in file order (or time order, when read so); odometry as rows (stamp, x, y,
    yaw) in time order; the laser's pose on the robot's base (x, y, yaw); lines skipped as
    (line number, reason); how many lines of other message types were passed over."""

    scans: list[CarmenScan]
    odom: np.ndarray
    laser_pose: tuple[float, float, float]
    source: str = ""
    skipped: list[tuple[int, str]] = field(default_factory=list)
    other_lines: int = 0
    # Why the scans' odometry poses are an already corrected trajectory (the reader found
    # so), or "" when they are taken for raw odometry.
    corrected_odometry: str = ""
    # Why the odometry poses are not all taken at their scans' instants, or "".
    odometry_timing: str = ""

    @property
    def duration(self) -> float:
        return self.scans[-1].stamp - self.scans[0].stamp if len(self.scans) > 1 else 0.0

    def scan_odometry(self) -> np.ndarray | None:
        """The odometry pose of every scan (N, 3) from its own line, or None when some
        scan's line carried none (then `odom` is interpolated at its stamp instead)."""
        if not self.scans or any(s.odom is None for s in self.scans):
            return None
        return np.array([s.odom for s in self.scans], dtype=np.float64)


def _floats(tokens: list[str], start: int, count: int, what: str) -> list[float]:
    if len(tokens) < start + count:
        raise CarmenError(f"{what}: expected {start + count} fields or more, got {len(tokens)}")
    try:
        return [float(t) for t in tokens[start : start + count]]
    except ValueError as exc:
        raise CarmenError(f"{what}: {exc}") from None


def _count(tokens: list[str], at: int, what: str) -> int:
    if len(tokens) <= at:
        raise CarmenError(f"{what}: the line ends before the number of readings")
    try:
        n = int(tokens[at])
    except ValueError:
        raise CarmenError(f"{what}: number of readings {tokens[at]!r} is not an integer") from None
    if n < 0:
        raise CarmenError(f"{what}: negative number of readings {n}")
    return n


def _no_return(ranges: np.ndarray, max_range: float) -> np.ndarray:
    """Ranges with readings at or past the maximum (the sensor's "nothing") as inf and
    readings of 0 or less (no measurement) as nan."""
    r = np.asarray(ranges, dtype=np.float64)
    r = np.where(r >= max_range - 1e-6, np.inf, r)
    return np.where(r > 0, r, np.nan)


def no_return_code(ranges: np.ndarray) -> float | None:
    """The value an old-style log writes for "no return" when it is below
    `FLASER_MAX_RANGE`: its largest reading, if at least `CODE_SHARE` of all readings
    are exactly that (a code, not a distance); None otherwise."""
    r = np.asarray(ranges, dtype=np.float64).ravel()
    r = r[np.isfinite(r) & (r > 0)]
    if r.size == 0:
        return None
    top = float(r.max())
    if top >= FLASER_MAX_RANGE:
        return None
    return top if np.count_nonzero(r == top) >= max(10, CODE_SHARE * r.size) else None


def _flaser_angles(n: int) -> tuple[float, float]:
    """First beam and increment of an old-style scan: 180 degrees from -90; 181 and 361
    beams include both ends (1 and 0.5 degree steps), other counts do not."""
    step = math.pi / (n - 1) if n in (181, 361) else math.pi / max(n, 1)
    return -math.pi / 2, step


@dataclass
class _Parsed:
    scans: list[CarmenScan] = field(default_factory=list)
    odom: list[tuple[float, float, float, float]] = field(default_factory=list)
    scan_odom: list[tuple[float, float, float, float]] = field(default_factory=list)
    mounts: list[tuple[float, float, float]] = field(default_factory=list)
    vertices: dict[int, tuple[float, float, float]] = field(default_factory=dict)
    edges: list[tuple[int, int, float, float, float]] = field(default_factory=list)


def timing_reason(scans: list[CarmenScan]) -> str:
    """Why the scans' odometry poses are not all taken at the scans' instants, or "":
    between consecutive scans (in the order given) the odometry turns faster than
    `FAST_TURN_RATE` at least `FAST_TURNS` times."""
    poses = [(s.stamp, s.odom[2]) for s in scans if s.odom is not None]
    if len(poses) < 2:
        return ""
    t, yaw = np.array(poses).T
    dt, turn = np.diff(t), np.abs((np.diff(yaw) + math.pi) % (2 * math.pi) - math.pi)
    ok = dt > 0
    rates = turn[ok] / dt[ok]
    fast = int(np.count_nonzero(rates > FAST_TURN_RATE))
    if fast < FAST_TURNS:
        return ""
    return (
        f"its odometry turns faster than {FAST_TURN_RATE:g} rad/s between two scans "
        f"{fast} times (up to {rates.max():.1f} rad/s), faster than a base turns: its "
        "poses are not all taken at their scans' instants"
    )


def _graph_line(kind: str, tokens: list[str], out: _Parsed) -> None:
    """A g2o pose graph's vertex or edge (id, x, y, yaw; from, to, dx, dy, dyaw)."""
    try:
        if kind == "VERTEX_SE2":
            out.vertices[int(tokens[1])] = (float(tokens[2]), float(tokens[3]), float(tokens[4]))
        else:
            out.edges.append((int(tokens[1]), int(tokens[2]), *map(float, tokens[3:6])))
    except (IndexError, ValueError):
        pass  # a graph line says nothing about the scans: one that cannot be read is left


def corrected_reason(out: _Parsed) -> str:
    """Why the laser lines' robot poses are an already corrected trajectory, or "": they
    must be the pose graph's vertices (same count, within 1 mm and 1 mrad) and meet its
    loop-closure edges within `CORRECTED_LOOP_TRANS` m and `CORRECTED_LOOP_ROT` rad on
    average."""
    loops = [e for e in out.edges if abs(e[1] - e[0]) > 1]
    ids = sorted(out.vertices)
    if len(loops) < CORRECTED_MIN_LOOPS or len(ids) != len(out.scan_odom):
        return ""
    v = np.array([out.vertices[i] for i in ids])
    laser = np.array([p[1:] for p in out.scan_odom])
    dyaw = np.abs((laser[:, 2] - v[:, 2] + math.pi) % (2 * math.pi) - math.pi)
    if np.abs(laser[:, :2] - v[:, :2]).max() > 1e-3 or dyaw.max() > 1e-3:
        return ""
    at = {i: k for k, i in enumerate(ids)}
    err_t, err_r = [], []
    for a, b, dx, dy, dth in loops:
        if a not in at or b not in at:
            return ""
        pa, pb = v[at[a]], v[at[b]]
        c, s = math.cos(pa[2]), math.sin(pa[2])
        ex, ey = pb[0] - pa[0], pb[1] - pa[1]
        err_t.append(math.hypot(c * ex + s * ey - dx, -s * ex + c * ey - dy))
        err_r.append(abs((pb[2] - pa[2] - dth + math.pi) % (2 * math.pi) - math.pi))
    t, r = float(np.mean(err_t)), float(np.mean(err_r))
    if t > CORRECTED_LOOP_TRANS or r > CORRECTED_LOOP_ROT:
        return ""
    return (
        f"its robot poses are its pose graph's vertices and meet its {len(loops)} "
        f"loop closures within {t:.3f} m and {math.degrees(r):.2f} deg on average: "
        "a trajectory already corrected, not raw odometry"
    )


def _mount(laser: list[float], robot: list[float]) -> tuple[float, float, float]:
    """The laser's pose on the base, from both poses in the odometry frame."""
    c, s = math.cos(robot[2]), math.sin(robot[2])
    dx, dy = laser[0] - robot[0], laser[1] - robot[1]
    yaw = (laser[2] - robot[2] + math.pi) % (2 * math.pi) - math.pi
    return (c * dx + s * dy, -s * dx + c * dy, yaw)


def _line(kind: str, tokens: list[str], out: _Parsed) -> None:
    if kind == "FLASER":
        n = _count(tokens, 1, kind)
        v = _floats(tokens, 2, n + 7, kind)
        laser, robot, stamp = v[n : n + 3], v[n + 3 : n + 6], v[n + 6]
        a0, da = _flaser_angles(n)
        # Raw readings: "no return" is decided over the whole log (`_flaser_codes`).
        out.scans.append(CarmenScan(stamp, np.array(v[:n]), a0, da, 0.0, tuple(robot)))
        out.scan_odom.append((stamp, *robot))
        out.mounts.append(_mount(laser, robot))
    elif kind in ("ROBOTLASER1", "RAWLASER1"):
        start, _fov, res, max_range, _acc, _mode = _floats(tokens, 2, 6, kind)
        n = _count(tokens, 8, kind)
        ranges = np.array(_floats(tokens, 9, n, kind))
        m = _count(tokens, 9 + n, kind + " remissions")
        at = 10 + n + m
        odom: tuple[float, float, float] | None = None
        if kind == "ROBOTLASER1":
            v = _floats(tokens, at, 12, kind)
            laser, robot, stamp = v[0:3], v[3:6], v[11]
            odom = (robot[0], robot[1], robot[2])
            out.scan_odom.append((stamp, *robot))
            out.mounts.append(_mount(laser, robot))
        else:
            stamp = _floats(tokens, at, 1, kind)[0]
        if not max_range > 0 or not res > 0:
            raise CarmenError(f"{kind}: maximum range {max_range} and resolution {res} must be > 0")
        out.scans.append(
            CarmenScan(stamp, _no_return(ranges, max_range), start, res, max_range, odom)
        )
    elif kind == "ODOM":
        x, y, th, _tv, _rv, _acc, stamp = _floats(tokens, 1, 7, kind)
        out.odom.append((stamp, x, y, th))


KNOWN = ("FLASER", "ROBOTLASER1", "RAWLASER1", "ODOM")
ORDERS = ("file", "time")


def _flaser_codes(scans: list[CarmenScan]) -> list[CarmenScan]:
    """Old-style scans (range_max 0: raw readings) with "no return" decided over all of
    them: readings past `FLASER_MAX_RANGE` or at the log's own code."""
    raw = [s for s in scans if s.range_max == 0.0]
    if not raw:
        return scans
    code = no_return_code(np.concatenate([s.ranges for s in raw]))
    top = FLASER_MAX_RANGE if code is None else code
    out = []
    for s in scans:
        if s.range_max == 0.0:
            r = np.asarray(s.ranges, dtype=np.float64)
            beyond = r > FLASER_MAX_RANGE if code is None else r >= code - 1e-6
            r = np.where(beyond, np.inf, np.where(r > 0, r, np.nan))
            s = CarmenScan(s.stamp, r, s.angle_min, s.angle_increment, top, s.odom)
        out.append(s)
    return out


def parse_carmen(
    lines: Iterable[str], source: str = "log", strict: bool = False, order: str = "file"
) -> CarmenLog:
    """A CarmenLog from the lines of a log. `strict`: a malformed line of a known type
    raises CarmenError naming `source` and the line; otherwise it is skipped and listed.
    `order`: "file" keeps the scans as the log holds them, "time" sorts them by stamp.

    Odometry comes from the robot poses on the laser lines (one per scan, what the
    mapping programs of these logs used); ODOM lines are used only when no laser line
    carries a pose. The laser's pose on the base is taken from the first laser line whose
    two poses are less than 1 m apart (these logs keep it fixed)."""
    if order not in ORDERS:
        raise ValueError(f"CARMEN log order {order!r}: choose from {', '.join(ORDERS)}")
    out = _Parsed()
    skipped: list[tuple[int, str]] = []
    other = 0
    for number, raw in enumerate(lines, start=1):
        tokens = raw.split()
        if not tokens or tokens[0].startswith("#"):
            continue
        kind = tokens[0]
        if kind not in KNOWN:
            other += 1
            if kind in ("VERTEX_SE2", "EDGE_SE2"):
                _graph_line(kind, tokens, out)
            continue
        try:
            _line(kind, tokens, out)
        except CarmenError as exc:
            if strict:
                raise CarmenError(f"{source}, line {number}: {exc}") from None
            skipped.append((number, str(exc)))
    if not out.scans:
        detail = f" ({len(skipped)} laser lines could not be read)" if skipped else ""
        raise CarmenError(
            f"{source}: no laser scans (FLASER, ROBOTLASER1 or RAWLASER1 lines){detail}"
        )
    track = out.scan_odom or out.odom
    odom = np.array(sorted(track), dtype=np.float64).reshape(-1, 4)
    if odom.shape[0]:
        # Keep one row per stamp (a log may repeat one): interpolation needs them apart.
        keep = np.concatenate([[True], np.diff(odom[:, 0]) > 0])
        odom = odom[keep]
    scans = _flaser_codes(out.scans)
    if order == "time":
        scans = sorted(scans, key=lambda s: s.stamp)
    # A laser pose far from the odometry is a corrected pose, not the mount: leave it.
    mount = next((m for m in out.mounts if math.hypot(m[0], m[1]) < 1.0), (0.0, 0.0, 0.0))
    timing = timing_reason(scans)
    return CarmenLog(scans, odom, mount, source, skipped, other, corrected_reason(out), timing)


def _text_lines(path: Path) -> list[str]:
    """The lines of a plain, gzip or zip (first member) text file."""
    data = path.read_bytes()
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    elif data[:4] == b"PK\x03\x04":
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            names = [n for n in z.namelist() if not n.endswith("/") and "__MACOSX" not in n]
            if not names:
                raise CarmenError(f"{path}: the zip archive holds no file")
            data = z.read(names[0])
    return data.decode("utf-8", errors="replace").splitlines()


def read_carmen(path: str | Path, strict: bool = False, order: str = "file") -> CarmenLog:
    """A CARMEN log file (.clf, .log, .g2o with ROBOTLASER1 lines; plain, .gz or .zip)."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such CARMEN log")
    return parse_carmen(_text_lines(p), str(p), strict, order)


def write_carmen(
    path: str | Path,
    scans: Iterable[CarmenScan],
    odom_at_scans: np.ndarray,
    laser_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    host: str = "robotrial",
) -> None:
    """Write scans with the robot's odometry pose at each (rows x, y, yaw) as ROBOTLASER1
    lines, and the same poses as ODOM lines: a log any CARMEN reader opens."""
    lx, ly, lth = laser_pose
    with open(path, "w") as f:
        f.write("# CARMEN log written by robotrial\n")
        for s, (x, y, th) in zip(scans, np.asarray(odom_at_scans), strict=True):
            c, sn = math.cos(th), math.sin(th)
            laser = (x + c * lx - sn * ly, y + sn * lx + c * ly, th + lth)
            r = np.where(np.isnan(s.ranges), 0.0, s.ranges)
            r = np.where(np.isinf(r), s.range_max, r)
            fov = s.angle_increment * max(len(r) - 1, 0)
            f.write(f"ODOM {x:.6f} {y:.6f} {th:.6f} 0 0 0 {s.stamp:.6f} {host} {s.stamp:.6f}\n")
            f.write(
                f"ROBOTLASER1 0 {s.angle_min:.6f} {fov:.6f} {s.angle_increment:.6f} "
                f"{s.range_max:.3f} 0.01 0 {len(r)} "
                + " ".join(f"{v:.3f}" for v in r)
                + f" 0 {laser[0]:.6f} {laser[1]:.6f} {laser[2]:.6f} {x:.6f} {y:.6f} {th:.6f}"
                f" 0 0 0 0 0 {s.stamp:.6f} {host} {s.stamp:.6f}\n"
            )


def parse_relations(lines: Iterable[str], source: str = "relations") -> np.ndarray:
    """Relations as rows (t1, t2, x, y, yaw) from ``t1 t2 x y z roll pitch yaw`` lines
    (the planar part; z, roll and pitch are 0 in the 2D data sets). A line that cannot
    be read raises CarmenError naming it."""
    rows = []
    for number, raw in enumerate(lines, start=1):
        tokens = raw.split()
        if not tokens or tokens[0].startswith("#"):
            continue
        try:
            if len(tokens) < 8:
                raise CarmenError(
                    f"expected 8 fields (t1 t2 x y z roll pitch yaw), got {len(tokens)}"
                )
            t1, t2, x, y, _z, _roll, _pitch, yaw = _floats(tokens, 0, 8, "relation")
        except CarmenError as exc:
            raise CarmenError(f"{source}, line {number}: {exc}") from None
        rows.append((t1, t2, x, y, yaw))
    if not rows:
        raise CarmenError(f"{source}: no relations")
    return np.array(rows, dtype=np.float64)


def read_relations(path: str | Path) -> np.ndarray:
    """A relation file of Kuemmerle et al. as rows (t1, t2, x, y, yaw)."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such relation file")
    return parse_relations(_text_lines(p), str(p))


def write_relations(path: str | Path, relations: np.ndarray) -> None:
    """Rows (t1, t2, x, y, yaw) as a relation file (z, roll, pitch written as 0)."""
    with open(path, "w") as f:
        for t1, t2, x, y, yaw in np.asarray(relations):
            f.write(f"{t1:.6f} {t2:.6f} {x:.6f} {y:.6f} 0 0 0 {yaw:.6f}\n")
