"""`robotrial sim` end to end: a short recorded run, its summary, plot and bad names."""

from __future__ import annotations

import json

from robotrial.cli import main
from robotrial.ros.playback import summary


def test_sim_command_records_and_summarizes(tmp_path, capsys):
    bag = tmp_path / "run.bag"
    code = main(
        [
            "sim",
            "--world",
            "room_a",
            "--robot",
            "mobile_manipulator",
            "--duration",
            "1",
            "--lidar-resolution",
            "0.4",
            "--record",
            str(bag),
            "--json",
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["sim_time_s"] == 1.0 and out["real_time_factor"] > 0
    assert out["messages"]["/points"] == 11 and out["messages"]["/scan"] == 11
    assert summary(bag) == out["messages"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [bag.name]  # no plot unless asked


def test_sim_command_names_unknown_world_and_robot(capsys):
    assert main(["sim", "--world", "room_q", "--duration", "1"]) == 2
    assert "unknown world 'room_q'" in capsys.readouterr().err
    assert main(["sim", "--robot", "r2d2", "--duration", "1"]) == 2
    assert "unknown robot 'r2d2'" in capsys.readouterr().err
    assert main(["sim", "--record", "run.txt", "--duration", "1"]) == 2
    assert ".mcap (ROS 2) or .bag" in capsys.readouterr().err


def test_keyboard_drive_needs_a_terminal(capsys, monkeypatch):
    monkeypatch.setattr("sys.stdin", open("/dev/null"))
    assert main(["sim", "--world", "room_a", "--drive", "keys", "--duration", "1"]) == 2
    assert "needs an interactive terminal" in capsys.readouterr().err


def test_bench_sim_reports_every_configuration(capsys):
    code = main(
        [
            "bench",
            "sim",
            "--duration",
            "0.1",
            "--camera-duration",
            "0.05",
            "--lidar-resolution",
            "0.4",
            "--json",
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["config"] for r in out["rtf"]][2] == "+ VLP-16 10 Hz + scan"
    assert all(r["rtf_wall"] > 0 for r in out["rtf"])
    assert {c["stream"] for c in out["sensor_costs"]} >= {"velodyne", "depth_camera", "odom"}
    assert out["arm_tracking"]["rms_rad"] < 0.01
