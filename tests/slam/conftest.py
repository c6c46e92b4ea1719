"""Short recordings of the simulated mobile manipulator for the SLAM tests, made once a
session with the real simulator: a square drive in room B (with /odom), and the same
scans without /odom as a ROS 1 bag."""

from __future__ import annotations

from pathlib import Path

import pytest

from robotrial.ros.playback import read_recording
from robotrial.ros.recorder import Recorder
from robotrial.trials.slam import Recording, load_recording, record_drive


@pytest.fixture(scope="session")
def slam_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("slam")


@pytest.fixture(scope="session")
def room_b_bag(slam_dir: Path) -> Path:
    """20 s, a 2 m square at 0.3 m/s from room B's default spawn, LiDAR every 0.4 deg."""
    path = slam_dir / "room_b.mcap"
    record_drive("room_b", path, duration=20.0, side=2.0, speed=0.3, lidar_resolution_deg=0.4)
    return path


@pytest.fixture(scope="session")
def room_b(room_b_bag: Path) -> Recording:
    return load_recording(room_b_bag)


@pytest.fixture(scope="session")
def no_odom_bag(room_b_bag: Path, slam_dir: Path) -> Path:
    """The same run as a ROS 1 bag holding /scan and /tf_static only."""
    path = slam_dir / "scans_only.bag"
    with Recorder(path) as rec:
        for topic, msg, t in read_recording(room_b_bag, ["/scan", "/tf_static"]):
            rec.write(topic, msg, t)
    return path
