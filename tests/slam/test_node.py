"""The SLAM node on the bus, fed by playback of a recording."""

from __future__ import annotations

import numpy as np

from robotrial.msgs.nav_msgs import OccupancyGrid
from robotrial.ros.bus import Bus
from robotrial.ros.playback import play
from robotrial.ros.slam_node import POSE_TOPIC, SlamNode
from robotrial.slam.gmapping import GMappingSlam
from robotrial.slam.params import GMappingParams


def test_map_tf_and_pose_come_out(room_b_bag):
    bus = Bus()
    node = SlamNode(bus, GMappingSlam(GMappingParams(particles=10)), map_update_interval=2.0)
    maps: list[OccupancyGrid] = []
    tfs, poses = [], []
    bus.subscribe("/map", maps.append)
    bus.subscribe(POSE_TOPIC, poses.append)
    bus.subscribe(
        "/tf", lambda m: tfs.extend(t for t in m.transforms if t.header.frame_id == "map")
    )
    play(room_b_bag, bus, ["/tf_static", "/odom", "/scan"])
    assert node.scans > 150 and node.dropped <= 1
    assert 5 <= len(maps) <= 12
    last = maps[-1]
    assert last.info.resolution == np.float32(0.05)
    data = np.asarray(last.data).reshape(last.info.height, last.info.width)
    assert (data == 100).sum() > 300
    assert tfs[-1].child_frame_id == "odom"
    assert len(poses) == node.scans
    # A late subscriber gets the latched map at once.
    late: list[OccupancyGrid] = []
    bus.subscribe("/map", late.append)
    assert len(late) == 1
    node.destroy()
