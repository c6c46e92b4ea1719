"""Both SLAM methods on a short simulated recording of room B, scored against the
ground truth; GMapping without odometry refuses with a clear error."""

from __future__ import annotations

import pytest

from robotrial.model import load_world
from robotrial.slam.gmapping import OdometryRequired
from robotrial.trials.slam import load_recording, room_size, run_slam, score


@pytest.fixture(scope="module")
def scores(room_b):
    world = load_world("room_b")
    return {
        m: score(run_slam(m, room_b), room_b, world, room_size(world))
        for m in ("gmapping", "hector")
    }


@pytest.mark.parametrize("method", ["gmapping", "hector"])
def test_trajectory_is_accurate(scores, method):
    s = scores[method]
    assert s["ate"]["rmse"] < 0.05
    assert s["rpe"]["rmse"] < 0.03


@pytest.mark.parametrize("method", ["gmapping", "hector"])
def test_map_matches_the_room(scores, method):
    s = scores[method]
    assert s["map"]["precision"] > 0.9
    assert s["map"]["recall"] > 0.85
    # The room is 7.78 x 7.62 m; the simulated scan itself reads walls ~1.3 cm short.
    assert s["room"]["error"] < 0.05
    assert abs(s["room"]["axes_yaw_deg"]) < 1.0


def test_gmapping_updates_as_the_robot_moves(scores):
    assert scores["gmapping"]["updates"] >= 3


def test_gmapping_without_odometry_says_what_is_missing(no_odom_bag):
    rec = load_recording(no_odom_bag)
    assert rec.odom.shape[0] == 0 and len(rec.scans) > 100
    with pytest.raises(OdometryRequired, match="/odom"):
        run_slam("gmapping", rec)
    # Hector needs scans alone.
    assert len(run_slam("hector", rec).poses) == len(rec.scans)


def test_ros_parameter_names_are_checked(room_b):
    with pytest.raises(ValueError, match="unknown parameter 'particle'"):
        run_slam("gmapping", room_b, {"particle": 10})
    run = run_slam("gmapping", room_b, {"particles": 5, "linearUpdate": 0.5})
    assert run.extra["updates"] >= 5
