"""The carry trial with the wall up: one robot maps the apartment, finds the cup with its
head camera, picks it by friction, carries it to the bedroom and sets it down there, never
reading where anything stands; and requests it cannot do, refused. The trial runs once
per session (tests/trials/conftest.py)."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from robotrial.model import load_world
from robotrial.model.robot import ModelError
from robotrial.model.world import world_from_dict
from robotrial.ros.playback import read_recording
from robotrial.trials.carry import (
    OBJECTS_TOPIC,
    PHASES,
    PLACE_TOLERANCE,
    CarrySetup,
    CarryTrial,
    catalogue_of,
    run_carry,
)

# what a robot of this build hears: its sensors, frames, its own map, the nav goals
ROBOT_TOPICS = {
    "/scan",
    "/odom",
    "/tf",
    "/tf_static",
    "/joint_states",
    "/map",
    "/initialpose",
    "/move_base_simple/goal",
    "/head_camera/image_raw",
    "/head_camera/camera_info",
    "/head_depth/depth/image_raw",
    "/head_depth/depth/camera_info",
}


def test_the_cup_ends_on_the_bed_upright_and_nothing_was_touched(cup_to_bedroom) -> None:
    result = cup_to_bedroom.result
    assert result.success, f"{result.failed_phase} ({result.cause}): {result.reason}"
    assert result.place_error is not None and result.place_error <= PLACE_TOLERANCE
    assert result.tilt is not None and result.tilt < 0.1
    assert result.collision == ""
    assert [p["phase"] for p in result.phases] == list(PHASES)
    assert result.oracles == []
    assert result.grasp.startswith("by friction: the fingers closed on the cup")
    # the robot found the cup itself: within 2 cm of where it stood (its map against
    # the world included)
    assert result.seen_error is not None and result.seen_error < 0.02


def test_the_robot_side_reads_no_truth(cup_to_bedroom) -> None:
    """Behind the wall: while it ran, any world loaded had its objects and furniture at
    NaN, and the robot side loaded none; its nodes subscribed only to what a robot's
    sensors and its own nodes give, never to the ground truth the world side publishes."""
    run = cup_to_bedroom
    assert run.worlds_loaded == 0
    heard = set().union(*run.subscriptions.values())
    assert {"/robot"} <= set(run.subscriptions) and len(run.subscriptions) >= 3
    assert heard <= ROBOT_TOPICS, heard - ROBOT_TOPICS
    assert "/ground_truth" not in heard and OBJECTS_TOPIC not in heard
    # the catalogue it was given holds sizes and colours, no poses
    for kind in catalogue_of(load_world("apartment")):
        assert not hasattr(kind, "pose")


def test_the_robot_navigated_on_the_map_it_built(cup_to_bedroom) -> None:
    result = cup_to_bedroom.result
    # the map covers the living room and the bedroom, with free and occupied cells
    assert result.map_image is not None
    assert (result.map_image == 0).sum() > 2000 and (result.map_image == 100).sum() > 200
    # its pose estimate (map frame, the spawn) stayed with the truth (world frame)
    sx, sy, syaw = result.map_in_world
    est = result.estimate[:, 1:]
    c, s = np.cos(syaw), np.sin(syaw)
    in_world = np.column_stack(
        [sx + c * est[:, 0] - s * est[:, 1], sy + s * est[:, 0] + c * est[:, 1]]
    )
    gap = np.linalg.norm(in_world - result.truth[:, 1:], axis=1)
    assert len(gap) > 100
    assert np.mean(gap) < 0.05 and np.max(gap) < 0.2, (np.mean(gap), np.max(gap))


def test_the_run_leaves_a_recording_a_summary_and_a_plot(cup_to_bedroom) -> None:
    out = cup_to_bedroom.out
    summary = json.loads((out / "carry_0.json").read_text())
    assert summary["success"] and summary["phases"][0]["phase"] == "mapping"
    assert summary["oracles"] == [] and summary["cause"] == ""
    assert (out / "carry_0.png").stat().st_size > 10_000
    topics: dict[str, int] = {}
    frames: set[str] = set()
    truth: set[str] = set()
    for topic, msg, _ in read_recording(out / "carry_0.mcap"):
        topics[topic] = topics.get(topic, 0) + 1
        if topic == "/tf":
            frames.update(t.child_frame_id for t in msg.transforms)
        if topic == OBJECTS_TOPIC:
            truth.update(t.child_frame_id for t in msg.transforms)
    for topic in ("/scan", "/odom", "/ground_truth", "/map", "/amcl_pose", "/gripper/command"):
        assert topics.get(topic, 0) > 0, f"{topic} missing from the recording"
    assert "odom" in frames and not any(f.startswith("object/") for f in frames)
    assert {"object/cup", "object/can"} <= truth


def test_requests_the_trial_cannot_do_are_refused_by_name(tmp_path: Path) -> None:
    with pytest.raises(KeyError, match=r"no room 'attic'.*living_room"):
        run_carry(CarrySetup(to="attic"), 0, tmp_path)
    with pytest.raises(ValueError, match="room 'study' has no place"):
        run_carry(CarrySetup(to="study"), 0, tmp_path)
    with pytest.raises(ValueError, match="'bed' is furniture"):
        run_carry(CarrySetup(object="bed"), 0, tmp_path)
    with pytest.raises(KeyError, match="world 'room_a' has no body 'cup'"):
        run_carry(CarrySetup(world="room_a"), 0, tmp_path)
    with pytest.raises(ValueError, match="no phase 'dance'"):
        run_carry(CarrySetup(), 0, None, until="dance")


def test_rooms_in_a_world_file_are_checked() -> None:
    world = load_world("apartment")
    assert world.room("kitchen").contains(8.0, 2.0)
    bad = {
        "rooms": [
            {"name": "den", "min": [0, 0], "max": [2, 2], "place": {"surface": "x", "xy": [1, 1]}}
        ]
    }
    with pytest.raises(ModelError, match=r"rooms\[0\].place.surface: no body 'x'"):
        world_from_dict(bad)
    with pytest.raises(ModelError, match=r"rooms\[0\].min must be below and left of max"):
        world_from_dict({"rooms": [{"name": "den", "min": [2, 2], "max": [0, 0]}]})


def test_a_contact_names_the_robot_s_body_that_touched_and_what_it_touched() -> None:
    trial = CarryTrial(CarrySetup(), 0, None)
    world = trial.sim.world
    x = world.data.qpos[world._base_q[0]]
    world.data.qpos[world._base_q[0]] = x - 2.7  # the base pushed into the west wall
    mujoco.mj_forward(world.model, world.data)
    trial._observe()
    assert trial.task.outcome.cause == "touched"
    assert trial.task.outcome.reason == "the robot's base_link touched wall/outer_west"
    assert trial.result.collision == "wall/outer_west"
