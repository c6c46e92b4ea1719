"""Message dataclasses: rosbridge JSON both ways, both spellings, CBOR, CDR, definitions,
and the generated TypeScript."""

from __future__ import annotations

import base64
import math
import re
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from rosbags.typesys import Stores, get_typestore

import robotrial.msgs as msgs
from robotrial import geometry
from robotrial.msgs import (
    MessageError,
    cbor,
    cdr,
    full_definition,
    lookup_message,
    lookup_service,
    typescript,
)
from robotrial.msgs.builtin_interfaces import Duration, Time
from robotrial.msgs.geometry_msgs import Pose
from robotrial.msgs.nav_msgs import OccupancyGrid, Odometry
from robotrial.msgs.robotrial_msgs import Box, PlanTask
from robotrial.msgs.sensor_msgs import CameraInfo, Image, JointState, LaserScan, PointCloud2
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.trajectory_msgs import JointTrajectory
from robotrial.msgs.visualization_msgs import Marker


def test_both_type_spellings_find_the_same_class() -> None:
    assert lookup_message("sensor_msgs/LaserScan") is LaserScan
    assert lookup_message("sensor_msgs/msg/LaserScan") is LaserScan
    assert lookup_message("time") is Time and lookup_message("duration") is Duration
    assert lookup_message("rosapi/TypeDef") is lookup_message("rosapi_msgs/msg/TypeDef")
    assert lookup_service("robotrial_msgs/PlanTask") is PlanTask
    assert lookup_service("rosapi/Topics") is lookup_service("rosapi_msgs/srv/Topics")
    assert lookup_message("no_msgs/Nothing") is None


def test_defaults_follow_ros() -> None:
    js = JointState()
    assert js.name == [] and js.header.stamp == Time(0, 0)
    assert Pose().orientation.w == 1.0
    assert CameraInfo().k == [0.0] * 9
    assert Image().data == b""


def test_json_round_trip_both_dialects() -> None:
    msg = JointState(
        header=Header(stamp=Time(sec=12, nanosec=34), frame_id="base"),
        name=["a", "b"],
        position=[0.5, -1.0],
        velocity=np.array([1.0, 2.0]),
    )
    ros2 = msg.to_dict()
    assert ros2["header"] == {"stamp": {"sec": 12, "nanosec": 34}, "frame_id": "base"}
    ros1 = msg.to_dict("ros1")
    assert ros1["header"] == {"seq": 0, "stamp": {"secs": 12, "nsecs": 34}, "frame_id": "base"}
    for d in (ros2, ros1):
        back = JointState.from_dict(d)
        assert back.header == msg.header and back.name == ["a", "b"]
        assert back.velocity == [1.0, 2.0]


def test_ros1_field_names_of_camera_info_and_marker() -> None:
    info = CameraInfo(d=[0.1], k=[1.0] * 9)
    d1 = info.to_dict("ros1")
    assert d1["D"] == [0.1] and "d" not in d1
    assert CameraInfo.from_dict(d1).k == [1.0] * 9
    m1 = Marker(text="hi").to_dict("ros1")
    assert "texture" not in m1 and "mesh_file" not in m1 and m1["text"] == "hi"
    assert "texture" in Marker().to_dict()


def test_uint8_arrays_are_base64_and_lists_are_accepted() -> None:
    cloud = PointCloud2(data=bytes([0, 1, 2, 255]))
    d = cloud.to_dict()
    assert d["data"] == base64.b64encode(bytes([0, 1, 2, 255])).decode()
    assert PointCloud2.from_dict(d).data == bytes([0, 1, 2, 255])
    assert PointCloud2.from_dict({"data": [0, 1, 2, 255]}).data == bytes([0, 1, 2, 255])
    with pytest.raises(MessageError, match=r"PointCloud2\.data: not valid base64"):
        PointCloud2.from_dict({"data": "!!"})
    with pytest.raises(MessageError, match=r"integers 0\.\.255"):
        PointCloud2.from_dict({"data": [256]})


def test_non_finite_floats_are_null_in_json() -> None:
    scan = LaserScan(ranges=[1.0, math.inf, math.nan])
    d = scan.to_dict()
    assert d["ranges"] == [1.0, None, None]
    back = LaserScan.from_dict(d)
    assert back.ranges[0] == 1.0 and math.isnan(back.ranges[1])


def test_errors_name_the_field_path() -> None:
    with pytest.raises(MessageError, match=r"obstacles\[1\]\.size\.x: expected a number"):
        PlanTask.Request.from_dict({"obstacles": [{}, {"size": {"x": "big"}}]})
    with pytest.raises(MessageError, match="has no field 'color'"):
        Box.from_dict({"color": 1})
    with pytest.raises(MessageError, match="out of range for int8"):
        OccupancyGrid.from_dict({"data": [0, 200]})
    with pytest.raises(MessageError, match="expected 36 elements"):
        Odometry.from_dict({"pose": {"covariance": [0.0]}})
    with pytest.raises(MessageError, match="expected true or false"):
        PlanTask.Response.from_dict({"success": "yes"})


def test_decoded_messages_own_their_lists_and_defaults() -> None:
    data = {"name": ["a", "b"], "position": [1.0, 2.0]}
    a = JointState.from_dict(data)
    a.name.append("c")
    a.position.append(3.0)
    assert data == {"name": ["a", "b"], "position": [1.0, 2.0]}
    b, c = JointState.from_dict({}), JointState.from_dict({})
    b.velocity.append(1.0)
    b.header.frame_id = "arm"
    assert c.velocity == [] and c.header.frame_id == ""
    assert JointState.from_dict({"position": [1, 2.5]}).position == [1.0, 2.5]
    with pytest.raises(MessageError, match=r"JointState\.name\[1\]: expected a string"):
        JointState.from_dict({"name": ["a", 2]})


def test_plan_task_matches_design() -> None:
    req = [s.name for s in PlanTask.Request.__fields_spec__]
    resp = [s.name for s in PlanTask.Response.__fields_spec__]
    assert req == ["current_joints", "obstacles", "object", "ee_goal", "planner", "time_limit"]
    assert resp == [
        "success",
        "message",
        "goal_joints",
        "trajectory",
        "planning_time",
        "error_code",
        "object_held",
    ]
    assert "int32 NO_IK_SOLUTION=-31" in full_definition(PlanTask.Response)
    assert full_definition(Box).startswith(
        "string id\ngeometry_msgs/Vector3 size\ngeometry_msgs/Pose pose\n"
    )


def test_pose_conversion_with_geometry() -> None:
    p = geometry.Pose.from_xyz_rpy((1, 2, 3), (0.1, 0.2, 0.3))
    back = Pose.from_pose(p).to_pose()
    assert np.allclose(back.matrix(), p.matrix())
    assert Time.from_sec(1.5) == Time(1, 500_000_000)
    assert Duration.from_sec(2.25).to_sec() == 2.25


def test_definitions_in_both_dialects() -> None:
    ros2 = full_definition(Odometry)
    assert "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec" in ros2
    ros1 = full_definition(Odometry, "ros1")
    assert "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id" in ros1
    assert "builtin_interfaces" not in ros1
    assert "float64[36] covariance" in ros1
    assert "int32 CUBE=1" in full_definition(Marker)


def test_cbor_typed_arrays() -> None:
    msg = JointState(name=["a"], position=[1.0, 2.0], effort=[math.inf])
    raw = cbor.dumps({"msg": msg.to_wire()})
    assert b"\xd8\x56" in raw  # tag 86: float64 little-endian typed array
    back = cbor.loads(raw)["msg"]
    assert back["position"] == [1.0, 2.0] and back["effort"] == [math.inf]
    cloud = PointCloud2(data=b"\x01\x02")
    assert cbor.loads(cbor.dumps(cloud.to_wire()))["data"] == b"\x01\x02"


STORE = get_typestore(Stores.ROS2_HUMBLE)


@pytest.mark.parametrize(
    "msg",
    [
        JointState(name=["a", "bc"], position=[1.0, 2.0], effort=[3.0]),
        Odometry(child_frame_id="base_link"),
        LaserScan(ranges=[1.0, 2.0], angle_max=3.0),
        Marker(text="hi", points=[], mesh_file=msgs.visualization_msgs.MeshFile(data=b"x")),
        JointTrajectory.from_dict(
            {"joint_names": ["j"], "points": [{"positions": [1.0], "time_from_start": {"sec": 1}}]}
        ),
        OccupancyGrid.from_dict({"info": {"width": 2, "height": 1}, "data": [-1, 100]}),
        CameraInfo(d=[0.1, 0.2], distortion_model="plumb_bob"),
        msgs.std_msgs.Empty(),
    ],
    ids=lambda m: type(m).__name__,
)
def test_cdr_matches_rosbags(msg) -> None:
    data = cdr.serialize(msg)
    name = type(msg).__ros_type__
    assert bytes(STORE.serialize_cdr(STORE.deserialize_cdr(data, name), name)) == data


ROS1_STORE = get_typestore(Stores.ROS1_NOETIC)


@pytest.mark.parametrize(
    "msg",
    [
        JointState(header=Header(stamp=Time(5, 6), frame_id="b"), name=["a"], position=[1.0]),
        Odometry(child_frame_id="base_link"),
        CameraInfo(d=[0.1, 0.2], distortion_model="plumb_bob"),
        Marker(text="hi", lifetime=Duration(2, 3)),
        OccupancyGrid.from_dict({"info": {"width": 2, "height": 1}, "data": [-1, 100]}),
    ],
    ids=lambda m: type(m).__name__,
)
def test_ros1_serialization_matches_rosbags(msg) -> None:
    data = cdr.serialize_ros1(msg)
    name = type(msg).__ros_type__
    back = ROS1_STORE.deserialize_ros1(data, name)
    assert bytes(ROS1_STORE.serialize_ros1(back, name)) == data


@given(
    st.lists(st.text(max_size=5), max_size=4),
    st.lists(st.floats(allow_nan=False, allow_infinity=False), max_size=4),
    st.integers(-(2**31), 2**31 - 1),
    st.integers(0, 2**32 - 1),
)
def test_json_round_trip_property(names, values, sec, nanosec) -> None:
    msg = JointState(header=Header(stamp=Time(sec, nanosec)), name=names, position=values)
    for dialect in ("ros1", "ros2"):
        assert JointState.from_dict(msg.to_dict(dialect)) == msg


def test_typescript_generation(tmp_path) -> None:
    out = tmp_path / "msgs.ts"
    assert typescript.main([str(out)]) == 0
    ts = out.read_text()
    assert "export interface JointState {\n  header: Header;\n  name: string[];" in ts
    assert "export interface PlanTaskRequest {" in ts and "ee_goal: Pose;" in ts
    assert "data: string | Uint8Array;" in ts
    assert (
        '"robotrial_msgs/srv/PlanTask": { request: PlanTaskRequest; response: PlanTaskResponse };'
        in ts
    )
    assert "export const Marker = { ARROW: 0, CUBE: 1," in ts
    assert '"/joint_states": "sensor_msgs/msg/JointState",' in ts
    names = re.findall(r"^export interface (\w+) ", ts, re.M)
    assert len(names) == len(set(names))
    for name in msgs.MESSAGES:
        assert f'"{name}":' in ts


def test_full_definitions_decode_cdr_like_ros2_tools() -> None:
    """mcap_ros2 parses `.msg` text the way Foxglove's and ROS 2's tools do: the
    definitions rosapi hands out must describe the bytes exactly."""
    from mcap_ros2._dynamic import generate_dynamic

    for name, cls in msgs.MESSAGES.items():
        decoder = generate_dynamic(name, full_definition(cls))[name]
        sample = cls()
        if "header" in cls.__field_map__:
            sample.header = Header(stamp=Time(7, 8), frame_id="map")
        decoded = decoder(cdr.serialize(sample))
        if "header" in cls.__field_map__:
            assert decoded.header.frame_id == "map" and decoded.header.stamp.nanosec == 8, name


def test_a_fresh_process_finds_every_type_by_name() -> None:
    # the packages' modules are imported on first use; a lookup by name must not depend
    # on which of them some earlier code happened to import
    code = (
        "import robotrial.msgs.core as core\n"
        "assert core.lookup_message('nav_msgs/Odometry').__name__ == 'Odometry'\n"
        "assert core.lookup_service('rosapi/Topics') is not None\n"
        "assert core.lookup_action('control_msgs/FollowJointTrajectory') is not None\n"
        "import robotrial.msgs as m\n"
        "assert 'visualization_msgs/msg/Marker' in m.MESSAGES\n"
        "assert m.tf2_msgs.TFMessage.__ros_type__ == 'tf2_msgs/msg/TFMessage'\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-800:]
