"""The pose graph's back end in its worker thread: the scan path keeps going while an
optimisation runs, and the result is swapped in when it is done."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from robotrial.slam.metrics import ate
from robotrial.slam.params import PoseGraphParams
from robotrial.slam.posegraph import PoseGraphSlam
from robotrial.trials.slam import Recording, make_slam, scan_beams, true_poses


class HeldPoseGraph(PoseGraphSlam):
    """The pose graph whose optimisation, once started in the worker, waits for `go`."""

    def __init__(self, params: PoseGraphParams) -> None:
        super().__init__(params)
        self.started = threading.Event()
        self.go = threading.Event()
        self.held_too_long = False

    def _optimise(self, nodes, scans):
        self.held_nodes = len(nodes)
        self.started.set()
        self.held_too_long = not self.go.wait(30.0)
        return super()._optimise(nodes, scans)


def test_scans_are_matched_while_the_optimisation_runs(room_b: Recording):
    # No bound on the nodes waiting for the worker: the scan path never waits for it.
    slam = HeldPoseGraph(PoseGraphParams(optimize_every=1, backend_max_backlog=10**6))
    for s in room_b.scans:
        slam.process(scan_beams(slam, s, room_b.laser_pose), s.stamp)
    # The square drive closes its loop: the worker reaches the optimisation and holds.
    assert slam.started.wait(30.0)
    # The robot stands at its last pose; its scans keep coming and are matched while the
    # optimisation is held (inline, the first of them would have waited the 30 s out).
    last = room_b.scans[-1]
    poses = []
    for i in range(20):
        beams = scan_beams(slam, last, room_b.laser_pose)
        poses.append(slam.process(beams, last.stamp + 0.1 * (i + 1)))
        assert slam.optimizations == 0 and slam.busy
    assert np.ptp(np.array(poses)[:, :2], axis=0).max() < 0.01
    slam.go.set()
    slam.settle()
    slam.close()
    assert not slam.held_too_long
    assert slam.optimizations >= 1 and slam.closures >= 1
    # Every scan keeps a pose, and the swapped-in trajectory is still right.
    stamps, traj = slam.trajectory()
    assert len(stamps) == len(room_b.scans) + 20
    ref, ok = true_poses(room_b, stamps)
    assert ok.sum() >= len(room_b.scans) - 1
    assert ate(traj[ok], ref)["rmse"] < 0.02


def test_the_scan_path_waits_for_a_back_end_that_falls_behind(room_b: Recording):
    """Scans replayed as fast as they are matched, the optimisation held: the scan path
    adds at most `backend_max_backlog` nodes past the held pass, then waits for it, and
    goes on once it is done."""
    slam = HeldPoseGraph(PoseGraphParams(optimize_every=1, backend_max_backlog=1))
    done = threading.Event()

    def drive() -> None:
        for s in room_b.scans:
            slam.process(scan_beams(slam, s, room_b.laser_pose), s.stamp)
        done.set()

    driver = threading.Thread(target=drive)
    driver.start()
    assert slam.started.wait(30.0)
    # Until the scan path stops adding nodes (it waits) or runs out of scans.
    count = -1
    while not done.is_set() and count != len(slam.nodes):
        count = len(slam.nodes)
        done.wait(0.5)
    assert not done.is_set(), "the drive ended before the back end fell behind"
    assert len(slam.nodes) <= slam.held_nodes + 2
    slam.go.set()
    driver.join(60.0)
    assert done.is_set() and not slam.held_too_long
    slam.settle()
    slam.close()
    assert len(slam.trajectory()[0]) == len(room_b.scans)


def test_background_and_inline_back_ends_agree_on_a_short_run(room_b: Recording):
    runs = {}
    for background in (True, False):
        slam = make_slam("graph", {"background": background, "optimize_every": 1})
        for s in room_b.scans:
            slam.process(scan_beams(slam, s, room_b.laser_pose), s.stamp)
        slam.settle()
        slam.close()
        runs[background] = slam
    a, b = runs[True], runs[False]
    assert a.closures >= 1 and b.closures >= 1
    # Nodes may fall at other scans (the pose is corrected at another moment), but every
    # scan's pose agrees, and both are right.
    (stamps, pa), (_, pb) = a.trajectory(), b.trajectory()
    assert np.hypot(*(pa[:, :2] - pb[:, :2]).T).max() < 0.02
    ref, ok = true_poses(room_b, stamps)
    assert ate(pa[ok], ref)["rmse"] < 0.01 and ate(pb[ok], ref)["rmse"] < 0.01


def test_in_lockstep_the_worker_gives_the_same_map_every_time(room_b: Recording):
    """A pass is swapped in when the next node is added, so the same scans give the same
    trajectory and map however the worker's timing falls (here with a busy thread
    beside it in one run)."""
    runs = []
    for busy in (False, True):
        stop = threading.Event()

        def spin(stop: threading.Event = stop) -> None:
            while not stop.is_set():
                sum(range(1000))

        spinner = threading.Thread(target=spin)
        if busy:
            spinner.start()
        slam = make_slam("graph", {"optimize_every": 1, "lockstep": True})
        for s in room_b.scans:
            slam.process(scan_beams(slam, s, room_b.laser_pose), s.stamp)
        slam.settle()
        slam.close()
        stop.set()
        if busy:
            spinner.join()
        runs.append((slam.trajectory()[1], slam.grid.logodds.copy(), slam.closures))
    (pa, ga, ca), (pb, gb, cb) = runs
    assert ca >= 1 and ca == cb
    assert np.array_equal(pa, pb) and np.array_equal(ga, gb)


def test_a_truth_value_that_is_not_one_is_refused():
    with pytest.raises(ValueError, match="'background'='sometimes'"):
        make_slam("graph", {"background": "sometimes"})
    assert make_slam("graph", {"background": "false"}).params.background is False
