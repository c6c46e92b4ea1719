"""Recordings that third-party ROS readers take as they are: ROS 1's C++ `rosbag_storage`
(what `rosbag play` and rqt_bag read with) and Python `rosbag` (Debian's python3-rosbag and
python3-roslz4, run with the system Python), rosbags-convert to ROS 2 bags (QoS kept), and
ROS 2 bags (a `ros2 bag record`-style folder or .db3 with types robotrial does not know)
read back by `robotrial bag info` and `robotrial slam --bag`."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from robotrial.cli import main
from robotrial.ros.playback import summary
from robotrial.trials.slam import load_recording

SYSTEM_PYTHON = "/usr/bin/python3"
# Debian's ROS 1 headers sit one folder deeper than the compiler looks (ament layout).
ROS_INCLUDES = ["pluginlib", "class_loader", "rcpputils", "rcutils", "ament_index_cpp"]
CPP_READER = r"""
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <iostream>
#include <map>
#include <string>
int main(int argc, char** argv) {
  rosbag::Bag bag(argv[1], rosbag::bagmode::Read);
  rosbag::View view(bag);
  std::map<std::string, int> counts;
  for (const rosbag::MessageInstance& m : view) counts[m.getTopic()] += m.size() > 0;
  for (const auto& kv : counts) std::cout << kv.first << " " << kv.second << "\n";
  return 0;
}
"""
PY_READER = """
import json, sys, rosbag
bag = rosbag.Bag(sys.argv[1])
counts, latching = {}, {}
for topic, msg, t in bag.read_messages():
    counts[topic] = counts.get(topic, 0) + 1
for c in bag._connections.values():
    latching[c.topic] = c.header.get("latching", b"0").decode()
print(json.dumps({"counts": counts, "latching": latching}))
"""


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, tuple[Path, dict]]:
    """A 2 s recording of the mobile manipulator in room A, as .bag (LZ4) and .mcap."""
    out = {}
    for name in ("run.bag", "run.mcap"):
        path = tmp_path_factory.mktemp("rec") / name
        args = ["sim", "--world", "room_a", "--duration", "2", "--lidar-resolution", "2"]
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            assert main([*args, "--record", str(path), "--json"]) == 0
        out[name] = (path, json.loads(printed.getvalue())["messages"])
    return out


def _system_python_has(module: str) -> None:
    probe = subprocess.run([SYSTEM_PYTHON, "-c", f"import {module}"], capture_output=True)
    if probe.returncode != 0:
        pytest.fail(f"{SYSTEM_PYTHON} lacks {module}: install python3-rosbag python3-roslz4")


def test_python_rosbag_reads_every_message_of_the_lz4_bag(runs):
    _system_python_has("rosbag")
    bag, produced = runs["run.bag"]
    proc = subprocess.run(
        [SYSTEM_PYTHON, "-c", PY_READER, str(bag)], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout)
    assert got["counts"] == produced == summary(bag)
    assert got["latching"]["/robot_description"] == "1"
    assert got["latching"]["/tf_static"] == "1" and got["latching"]["/scan"] == "0"


def test_cpp_rosbag_storage_reads_every_message(runs, tmp_path):
    gxx = shutil.which("g++")
    if gxx is None or not Path("/usr/include/rosbag/bag.h").is_file():
        pytest.fail("g++ and librosbag-storage-dev are needed: see .ci/run's install list")
    src, exe = tmp_path / "reader.cpp", tmp_path / "reader"
    src.write_text(CPP_READER)
    flags = [f"-I/usr/include/{d}" for d in ROS_INCLUDES]
    libs = ["-lrosbag_storage", "-lroslz4", "-lrostime", "-lcpp_common", "-lconsole_bridge"]
    build = subprocess.run(
        [gxx, "-std=c++17", str(src), "-o", str(exe), *flags, *libs, "-lboost_filesystem"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert build.returncode == 0, build.stderr
    bag, produced = runs["run.bag"]
    proc = subprocess.run([str(exe), str(bag)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "invalid time" not in proc.stderr
    counts = {t: int(n) for t, n in (line.split() for line in proc.stdout.splitlines())}
    assert counts == produced
    assert counts["/tf_static"] == 1 and counts["/robot_description"] == 1


def _convert(src: Path, dst: Path) -> dict:
    exe = Path(sys.executable).parent / "rosbags-convert"
    proc = subprocess.run(
        [str(exe), "--src", str(src), "--dst", str(dst)], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    meta = yaml.safe_load((dst / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return {t["topic_metadata"]["name"]: t for t in meta["topics_with_message_count"]}


def _durability(topic: dict) -> str:
    qos = topic["topic_metadata"]["offered_qos_profiles"]
    profiles = yaml.safe_load(qos) if isinstance(qos, str) else qos
    return str(profiles[0]["durability"]).lower()


def test_rosbags_convert_keeps_latched_topics_transient_local(runs, tmp_path):
    mcap, produced = runs["run.mcap"]
    topics = _convert(mcap, tmp_path / "from_mcap")
    for name in ("/tf_static", "/robot_description"):
        assert _durability(topics[name]) in ("1", "transient_local"), topics[name]
    assert _durability(topics["/scan"]) in ("2", "volatile")
    assert {t: v["message_count"] for t, v in topics.items()} == produced


def test_ros2_bag_folders_and_db3_are_read(runs, tmp_path, capsys):
    """A ROS 2 bag with a type robotrial has no class for (rcl_interfaces/msg/Log, as
    `ros2 bag record -a` catches from /rosout) is listed from its index; SLAM reads the
    scans and odometry of a ROS 2 bag folder."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    Log = store.types["rcl_interfaces/msg/Log"]
    Time = store.types["builtin_interfaces/msg/Time"]
    folder = tmp_path / "rosout"
    with Writer(folder, version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
        conn = w.add_connection("/rosout", Log.__msgtype__, typestore=store)
        for i in range(3):
            log = Log(Time(i, 0), 20, "node", f"line {i}", "f.cpp", "fn", i)
            w.write(conn, i * 10**9 + 1, store.serialize_cdr(log, Log.__msgtype__))
    for path in (folder, next(folder.glob("*.db3"))):
        assert main(["bag", "info", str(path), "--json"]) == 0
        got = json.loads(capsys.readouterr().out)
        assert got["messages"] == {"/rosout": 3}
        assert got["types"] == {"/rosout": "rcl_interfaces/msg/Log"}

    mcap, produced = runs["run.mcap"]
    converted = tmp_path / "ros2_run"
    _convert(mcap, converted)
    assert main(["bag", "info", str(converted), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["messages"] == produced
    rec = load_recording(converted)  # what `robotrial slam --bag FOLDER` reads
    assert len(rec.scans) == produced["/scan"] and len(rec.odom) > 0
