"""CARMEN logs and relation files on data we make: the simulated room B run written as a
log (its scans and odometry) with relations from its ground truth, read back, mapped by
Hector and scored with the relative-pose error of Kuemmerle et al.; malformed lines."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from robotrial.cli import main
from robotrial.model import load_world
from robotrial.model.carmen import (
    CarmenError,
    CarmenScan,
    parse_carmen,
    parse_relations,
    read_carmen,
    write_carmen,
    write_relations,
)
from robotrial.slam.metrics import relation_metric
from robotrial.slam.scan import beams, relative
from robotrial.trials.carmen import recording_from_log
from robotrial.trials.slam import make_slam, map_accuracy, map_pose_in_world, run_slam, true_poses


@pytest.fixture(scope="module")
def room_b_log(room_b, tmp_path_factory):
    """room B's scans and odometry as a CARMEN log, and relations from the true poses
    between scans 1, 5 and 20 apart (as the published relation files pair scans)."""
    folder = tmp_path_factory.mktemp("carmen")
    stamps = np.array([s.stamp for s in room_b.scans])
    odom = np.array([room_b.odom_at(t) for t in stamps])
    scans = [
        CarmenScan(s.stamp, s.ranges, s.angle_min, s.angle_increment, s.range_max)
        for s in room_b.scans
    ]
    write_carmen(folder / "room_b.clf", scans, odom, room_b.laser_pose)
    truth, ok = true_poses(room_b, stamps)
    assert ok.all()
    rows = [
        (stamps[i], stamps[i + k], *relative(truth[i], truth[i + k]))
        for k in (1, 5, 20)
        for i in range(0, len(stamps) - k, 3)
    ]
    write_relations(folder / "room_b.relations", np.array(rows))
    return folder / "room_b.clf", folder / "room_b.relations"


def test_log_reads_back_the_scans_and_odometry(room_b, room_b_log):
    log = read_carmen(room_b_log[0])
    assert len(log.scans) == len(room_b.scans) and not log.skipped
    a, b = room_b.scans[7], log.scans[7]
    assert b.stamp == pytest.approx(a.stamp, abs=1e-6)
    assert b.angle_min == pytest.approx(a.angle_min, abs=1e-6)
    assert b.angle_increment == pytest.approx(a.angle_increment, abs=1e-6)
    finite = np.isfinite(a.ranges)
    assert np.array_equal(np.isfinite(b.ranges), finite)
    assert np.allclose(b.ranges[finite], a.ranges[finite], atol=6e-4)
    assert np.allclose(log.laser_pose, room_b.laser_pose, atol=1e-5)
    odom = room_b.odom_at(a.stamp)
    assert np.allclose(log.odom[7, 1:], odom, atol=1e-5)


def test_hector_on_the_log_scores_small_relation_error_and_maps_the_room(room_b, room_b_log):
    rec = recording_from_log(read_carmen(room_b_log[0]))
    run = run_slam("hector", rec)
    rel = parse_relations(room_b_log[1].read_text().splitlines())
    s = relation_metric(run.stamps, run.poses, rel)
    assert s["used"] == len(rel)
    assert s["trans_mean"] < 0.01 and s["trans_max"] < 0.05
    assert s["rot_deg_mean"] < 0.2
    # The same scans from the original recording, scored on the world's true walls.
    acc = map_accuracy(
        run.grid, map_pose_in_world(room_b), load_world("room_b"), room_b.laser_height
    )
    assert acc["precision"] > 0.9 and acc["recall"] > 0.85
    # The noisy odometry alone turns far worse on the same relations than scan matching.
    odo = relation_metric(rec.odom[:, 0], rec.odom[:, 1:], rel)
    assert odo["rot_deg_mean"] > 5 * s["rot_deg_mean"]


def test_relation_metric_of_a_known_offset():
    """An estimate whose every relative motion is 0.1 m and 2 degrees off its relation."""
    stamps = np.arange(4.0)
    poses = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], dtype=float)
    yaw = math.radians(2.0)
    rel = np.array([[0, 1, 0.9, 0, yaw], [1, 3, 2.1, 0, -yaw], [0.004, 2, 2.0, 0.1, yaw]])
    s = relation_metric(stamps, poses, rel)
    assert s["used"] == 3
    assert s["trans_mean"] == pytest.approx(0.1, abs=1e-9)
    assert s["trans_sq_mean"] == pytest.approx(0.01, abs=1e-9)
    assert s["rot_deg_mean"] == pytest.approx(2.0, abs=1e-9)
    assert s["rot_sq_deg_mean"] == pytest.approx(4.0, abs=1e-9)
    # A relation whose stamps no estimated pose is near is left out, and counted.
    s = relation_metric(stamps, poses, np.vstack([rel, [0.5, 2, 1, 0, 0]]))
    assert s["relations"] == 4 and s["used"] == 3


FLASER = "FLASER 180 " + " ".join(["2.5"] * 179) + " 81.91 1 2 0.1 1 2 0.1 100.5 host 100.6"


def test_old_style_flaser_lines():
    log = parse_carmen(
        ["# comment", "PARAM robot_width 0.5", FLASER, FLASER.replace("100.5", "100.7")]
    )
    assert len(log.scans) == 2 and log.other_lines == 1
    s = log.scans[0]
    assert s.angle_min == pytest.approx(-math.pi / 2)
    assert s.angle_increment == pytest.approx(math.pi / 180)
    assert s.ranges[0] == 2.5 and math.isinf(s.ranges[-1])
    assert np.allclose(log.odom, [[100.5, 1, 2, 0.1], [100.7, 1, 2, 0.1]])


def test_compressed_logs_read_like_plain_ones(tmp_path):
    import gzip
    import zipfile

    text = "\n".join([FLASER, FLASER.replace("100.5", "100.7")]) + "\n"
    (tmp_path / "a.clf.gz").write_bytes(gzip.compress(text.encode()))
    with zipfile.ZipFile(tmp_path / "a.zip", "w") as z:
        z.writestr("a.clf", text)
    for name in ("a.clf.gz", "a.zip"):
        log = read_carmen(tmp_path / name)
        assert [s.stamp for s in log.scans] == [100.5, 100.7]


def test_malformed_line_names_the_line_or_is_skipped_and_counted():
    lines = [FLASER, "ODOM 1 2 0.1 0 0 0 100.55 host 100.6", "FLASER 180 1.0 2.0 oops", FLASER]
    with pytest.raises(CarmenError, match=r"bad\.clf, line 3: FLASER"):
        parse_carmen(lines, "bad.clf", strict=True)
    log = parse_carmen(lines, "bad.clf")
    assert len(log.scans) == 2 and [n for n, _ in log.skipped] == [3]
    with pytest.raises(CarmenError, match="line 2: expected 8 fields"):
        parse_relations(["1 2 0 0 0 0 0 0", "1 2 0.5"], "r.txt")
    with pytest.raises(CarmenError, match="no laser scans"):
        parse_carmen(["ODOM 1 2 0.1 0 0 0 100.55 host 100.6"])


def test_cli_maps_a_log_and_prints_time_per_scan_and_relation_error(room_b_log, tmp_path, capsys):
    log, rel = room_b_log
    bad = tmp_path / "with_bad_line.clf"
    bad.write_text(log.read_text() + "ROBOTLASER1 0 -1.5 3.1 0.01 30 0.01 0 5 1 2\n")
    out = tmp_path / "room_b_log.yaml"
    code = main(["slam", "--method", "hector", "--log", str(bad), "--relations", str(rel),
                 "-o", str(out), "--json"])  # fmt: skip
    assert code == 0
    result = json.loads(capsys.readouterr().out)
    assert result["skipped_lines"] == 1
    assert result["time_per_scan_ms"] > 0
    assert result["relations"]["trans_mean"] < 0.03
    assert out.is_file() and out.with_suffix(".pgm").is_file()
    code = main(["slam", "--log", str(tmp_path / "none.clf"), "-o", str(tmp_path / "x")])
    assert code == 2 and "no such CARMEN log" in " ".join(capsys.readouterr().err.split())
    code = main(["slam", "--bag", str(log), "--relations", str(rel), "-o", str(tmp_path / "y")])
    assert code == 2 and "--relations scores a --log run" in capsys.readouterr().err


def test_a_log_replay_runs_the_pose_graph_in_lockstep_unless_told(room_b_log, tmp_path, capsys):
    """A replay's result does not hang on the scheduler: the same log twice gives the
    same trajectory and map; `--param lockstep=false` gives the threaded back end."""
    log, rel = room_b_log
    results, maps = [], []
    for name, extra in (("a", []), ("b", []), ("c", ["--param", "lockstep=false"])):
        out = tmp_path / name
        argv = ["slam", "--method", "graph", "--log", str(log), "--relations", str(rel)]
        assert main([*argv, *extra, "-o", str(out), "--json"]) == 0
        results.append(json.loads(capsys.readouterr().out))
        maps.append(out.with_suffix(".pgm").read_bytes())
    a, b, c = results
    assert a["back_end"] == b["back_end"] == "lockstep" and c["back_end"] == "threaded"
    assert a["relations"] == b["relations"] and maps[0] == maps[1]
    assert a["relations"]["trans_mean"] < 0.03


def test_bench_real_runs_what_it_finds_and_skips_the_rest(room_b_log, tmp_path, capsys):
    """A log named like the Intel one runs and is scored, the odometry alone beside it;
    ACES, FR079 and Killian (no fetching) are reported as skipped, naming the folder, and
    the run still succeeds."""
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "intel.clf").write_bytes(room_b_log[0].read_bytes())
    (logs / "intel.relations").write_bytes(room_b_log[1].read_bytes())
    out = tmp_path / "bench" / "slam.json"
    argv = ["bench", "slam_real", "--log-dir", str(logs), "--no-fetch", "--methods", "hector"]
    assert main([*argv, "-o", str(out)]) == 0
    captured = capsys.readouterr()
    printed = " ".join((captured.out + captured.err).split())
    assert f"ACES building: skipped, no log in {logs}" in printed
    assert "MIT Killian Court: skipped" in printed
    result = json.loads(out.with_name("slam_real.json").read_text())
    intel = result["sets"]["intel"]
    assert intel["hector"]["relations"]["trans_mean"] < 0.01
    assert intel["hector"]["peak_mb"] > 0 and intel["hector"]["time_per_scan_ms"] > 0
    # Times on a shared machine come with the load they were taken at.
    assert len(intel["hector"]["load"]) == 2 and result["load_end"] >= 0
    assert "load average (1 min)" in printed
    # The simulated odometry (heading scale off by a few per cent) scores far worse.
    assert (
        intel["odometry"]["relations"]["rot_deg_mean"]
        > 5 * intel["hector"]["relations"]["rot_deg_mean"]
    )
    assert result["sets"]["aces"] == {"skipped": True}


def _flaser(stamp: float, x: float, readings: list[float]) -> str:
    r = " ".join(f"{v:g}" for v in readings)
    return f"FLASER {len(readings)} {r} {x} 0 0 {x} 0 0 {stamp} host {stamp}"


def test_no_return_and_no_measurement_as_each_log_format_writes_them():
    # Old style: past 80 m is the SICK's "no return" code (81.83 here), 0 no measurement.
    s = parse_carmen([_flaser(5.0, 0.0, [0.0] + [3.0] * 178 + [81.83, 79.5])]).scans[0]
    assert math.isnan(s.ranges[0]) and s.ranges[1] == 3.0
    assert math.isinf(s.ranges[179]) and s.ranges[180] == 79.5
    # A log whose largest reading recurs as no distance does: its code, below 80 m.
    lines = [_flaser(t, 0.0, [5.6] * 100 + [2.0 + 0.01 * t] * 81) for t in (1.0, 2.0)]
    s = parse_carmen(lines).scans[0]
    assert np.isinf(s.ranges[:100]).all() and np.isfinite(s.ranges[100:]).all()
    assert s.range_max == 5.6
    # New style: the line's own maximum range (50 m; this scanner writes 51.06 past it).
    ranges = " ".join(["51.06", "12.5", "0"])
    line = f"ROBOTLASER1 0 -1.5 3.1 0.01 50.0 0.1 0 3 {ranges} 0 0 0 0 0 0 0 0 0 0 0 0 0 7.0 h 7.0"
    r = parse_carmen([line]).scans[0].ranges
    assert math.isinf(r[0]) and r[1] == 12.5 and math.isnan(r[2])


def test_scans_keep_the_file_order_and_their_own_odometry():
    """Stamps that step back (as some loggers wrote them) do not reorder the scans; each
    scan keeps the odometry pose of its own line."""
    lines = [_flaser(t, x, [2.0] * 181) for t, x in ((10.0, 0.0), (10.2, 0.1), (9.6, 0.2))]
    log = parse_carmen(lines)
    assert [s.stamp for s in log.scans] == [10.0, 10.2, 9.6]
    rec = recording_from_log(log)
    assert rec.scan_odom is not None and rec.scan_odom[:, 0].tolist() == [0.0, 0.1, 0.2]
    assert [s.stamp for s in parse_carmen(lines, order="time").scans] == [9.6, 10.0, 10.2]
    with pytest.raises(ValueError, match="order 'random'"):
        parse_carmen(lines, order="random")


def test_range_limits_leave_no_return_out_and_cut_long_beams():
    """GMapping's two limits: past maxRange a beam is left out (so "no return" clears
    nothing), between maxUrange and maxRange it frees space up to maxUrange."""
    r = np.array([2.0, np.inf, 45.0, np.nan])
    b = beams(r, 0.0, 0.1, 0.0, 30.0, max_range=40.0)
    assert b.ends.shape[0] == 1 and b.hit.all()
    b = beams(r, 0.0, 0.1, 0.0, 30.0, max_range=50.0)
    assert b.hit.tolist() == [True, False] and np.hypot(*b.ends[1]) == pytest.approx(30.0)
    # slam_gmapping: maxRange unset is range_max - 0.01, maxUrange unset is maxRange.
    assert make_slam("gmapping").range_limits(50.0) == pytest.approx((0.0, 49.99, 49.99))
    limits = make_slam("gmapping", {"maxUrange": 30}).range_limits(50.0)
    assert limits == pytest.approx((0.0, 49.99, 30.0))
    # Hector leaves out everything past laser_max_dist.
    assert make_slam("hector").range_limits(80.0) == pytest.approx((0.4, 30.0, 30.0))


def _g2o(truth: np.ndarray, poses: np.ndarray, loops: list[tuple[int, int]]) -> list[str]:
    """A g2o file as the rtb-data logs are: vertices at `poses`, sequential and
    loop-closure edges measuring the motion along `truth`, and one ROBOTLASER1 line a
    vertex carrying its pose (3 beams of 2 m)."""
    out = [f"VERTEX_SE2 {i} {x} {y} {t}" for i, (x, y, t) in enumerate(poses)]
    for a, b in [(i, i + 1) for i in range(len(truth) - 1)] + loops:
        z = relative(truth[a], truth[b])
        out.append(f"EDGE_SE2 {a} {b} {z[0]} {z[1]} {z[2]} 500 0 0 500 0 5000")
    for i, (x, y, t) in enumerate(poses):
        out.append(
            f"ROBOTLASER1 0 -1.57 3.14 1.57 50 0.1 0 3 2 2 2 0 {x} {y} {t} {x} {y} {t} "
            f"0 0 0 0 0 {100 + 1.7 * i} host {100 + 1.7 * i}"
        )
    return out


def test_a_g2o_log_whose_poses_meet_its_loop_closures_declares_a_corrected_trajectory():
    """The Killian Court log of rtb-data carries the corrected trajectory on its laser
    lines: the reader says so, and GMapping and the pose graph are then run with motion
    models for such poses; a log whose poses miss its loop closures (raw odometry)
    declares nothing."""
    from robotrial.slam.scan import compose
    from robotrial.trials.carmen import CORRECTED_GRAPH_MOTION, CORRECTED_MOTION, declared_params

    a = np.linspace(0, 4 * np.pi, 60, endpoint=False)
    truth = np.stack([5 * np.cos(a), 5 * np.sin(a), a + np.pi / 2], axis=1)
    loops = [(i, i + 30) for i in range(0, 30, 2)]
    log = parse_carmen(_g2o(truth, truth, loops), "killian.g2o")
    assert "15 loop closures" in log.corrected_odometry
    assert declared_params(log, "gmapping") == (CORRECTED_MOTION, log.corrected_odometry)
    assert declared_params(log, "graph") == (CORRECTED_GRAPH_MOTION, log.corrected_odometry)
    assert declared_params(log, "hector")[0] == {}
    # Odometry that turns 0.004 rad a step too far: 0.12 rad off at the next lap.
    raw = [truth[0]]
    for i in range(59):
        raw.append(compose(raw[-1], relative(truth[i], truth[i + 1]) + np.array([0, 0, 0.004])))
    log = parse_carmen(_g2o(truth, np.array(raw), loops), "raw.g2o")
    assert log.corrected_odometry == "" and declared_params(log, "gmapping")[0] == {}
    assert declared_params(log, "graph")[0] == {}


def test_a_corrected_log_drifted_into_raw_odometry_is_seeded_and_declares_nothing():
    """The raw-odometry version of a corrected log (`drift_odometry`): the same scans,
    each motion a few per cent off and the heading drifting, so that two laps no longer
    meet; the same seed gives the same poses, another seed others; the reader then
    declares no corrected trajectory; a log without odometry poses is refused by name."""
    from robotrial.trials.carmen import OdometryDrift, declared_params, drift_odometry

    a = np.linspace(0, 4 * np.pi, 60, endpoint=False)
    truth = np.stack([5 * np.cos(a), 5 * np.sin(a), a + np.pi / 2], axis=1)
    log = parse_carmen(_g2o(truth, truth, [(i, i + 30) for i in range(0, 30, 2)]), "k.g2o")
    assert log.corrected_odometry
    raw = drift_odometry(log, OdometryDrift(seed=3))
    poses = raw.scan_odometry()
    assert raw.corrected_odometry == "" and declared_params(raw, "graph")[0] == {}
    assert [s.stamp for s in raw.scans] == [s.stamp for s in log.scans]
    np.testing.assert_allclose(poses[0], truth[0], atol=1e-9)
    np.testing.assert_allclose(raw.odom[:, 1:], poses)
    steps = [relative(poses[i], poses[i + 1]) for i in range(59)]
    true_steps = [relative(truth[i], truth[i + 1]) for i in range(59)]
    ratio = [np.hypot(*d[:2]) / np.hypot(*t[:2]) for d, t in zip(steps, true_steps, strict=True)]
    assert 0.85 < min(ratio) and max(ratio) < 1.2 and np.std(ratio) > 0.01
    # One lap later the odometry no longer comes back to where it was.
    assert np.hypot(*(poses[30] - poses[0])[:2]) > 0.3
    again = drift_odometry(log, OdometryDrift(seed=3)).scan_odometry()
    np.testing.assert_array_equal(again, poses)
    assert np.abs(drift_odometry(log, OdometryDrift(seed=4)).scan_odometry() - poses).max() > 0.1
    bare = parse_carmen([_flaser(1.0, 0.0, [3.0] * 180)])
    bare.scans[0] = CarmenScan(1.0, bare.scans[0].ranges, 0.0, 0.01, 80.0)
    with pytest.raises(ValueError, match="carries no odometry pose"):
        drift_odometry(bare, OdometryDrift())


def test_a_log_whose_odometry_turns_faster_than_a_base_declares_its_timing():
    """Odometry poses that turn 0.8 rad in a 0.2 s step (4 rad/s) and give it back, three
    times: the poses are not all taken at their scans' instants, and the pose graph is
    run with a timing uncertainty; a steady 1 rad/s spin declares nothing."""
    from robotrial.trials.carmen import TIMING, declared_params

    def flaser(turns: list[float]) -> list[str]:
        yaw, out, r = 0.0, [], " ".join(["3"] * 181)
        for i, d in enumerate(turns):
            yaw += d
            t = 100 + 0.2 * i
            out.append(f"FLASER 181 {r} 1 2 {yaw} 1 2 {yaw} {t} host {t}")
        return out

    steady = [0.2] * 30
    log = parse_carmen(flaser(steady))
    assert log.odometry_timing == "" and declared_params(log, "graph")[0] == {}
    jumpy = steady.copy()
    for i in (5, 15, 25):
        jumpy[i], jumpy[i + 1] = 0.8, -0.4
    log = parse_carmen(flaser(jumpy))
    assert "3 times" in log.odometry_timing
    assert declared_params(log, "graph") == (TIMING, log.odometry_timing)
