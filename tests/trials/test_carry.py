"""The carry trial: one robot maps the apartment, drives on its own map, picks the cup,
carries it to the bedroom and sets it down there; and requests it cannot do, refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robotrial.model import load_world
from robotrial.model.robot import ModelError
from robotrial.model.world import world_from_dict
from robotrial.ros.playback import read_recording
from robotrial.trials.carry import PHASES, PLACE_TOLERANCE, CarrySetup, run_carry


@pytest.fixture(scope="module")
def cup_to_bedroom(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("carry")
    return run_carry(CarrySetup(object="cup", to="bedroom"), 0, out), out


def test_the_cup_ends_on_the_bed_upright_and_nothing_was_touched(cup_to_bedroom) -> None:
    result, _ = cup_to_bedroom
    assert result.success, f"{result.failed_phase}: {result.reason}"
    assert result.place_error is not None and result.place_error <= PLACE_TOLERANCE
    assert result.tilt is not None and result.tilt < 0.1
    assert result.collision == ""
    assert [p["phase"] for p in result.phases] == list(PHASES)
    assert "both fingers touched" in result.grasp


def test_the_robot_navigated_on_the_map_it_built(cup_to_bedroom) -> None:
    result, _ = cup_to_bedroom
    # the map covers the living room and the bedroom, with free and occupied cells
    assert result.map_image is not None
    assert (result.map_image == 0).sum() > 2000 and (result.map_image == 100).sum() > 200
    # the localization the robot drove on stayed with the truth (both in the map frame)
    assert len(result.truth) == len(result.estimate) > 100


def test_the_can_goes_from_the_kitchen_table_to_the_bed() -> None:
    """Another object from another room: the can is picked off the kitchen table (a
    drive across the apartment on the built map) and set down on the bed."""
    result = run_carry(CarrySetup(object="can", to="bedroom"), 3)
    assert result.success, f"{result.failed_phase}: {result.reason}"
    assert result.place_error is not None and result.place_error <= PLACE_TOLERANCE
    assert result.collision == ""


def test_the_run_leaves_a_recording_a_summary_and_a_plot(cup_to_bedroom) -> None:
    _, out = cup_to_bedroom
    summary = json.loads((out / "carry_0.json").read_text())
    assert summary["success"] and summary["phases"][0]["phase"] == "mapping"
    assert (out / "carry_0.png").stat().st_size > 10_000
    topics: dict[str, int] = {}
    frames: set[str] = set()
    for topic, msg, _ in read_recording(out / "carry_0.mcap"):
        topics[topic] = topics.get(topic, 0) + 1
        if topic == "/tf":
            frames.update(t.child_frame_id for t in msg.transforms)
    for topic in ("/scan", "/odom", "/ground_truth", "/map", "/amcl_pose", "/cmd_vel"):
        assert topics.get(topic, 0) > 0, f"{topic} missing from the recording"
    assert {"object/cup", "object/can", "odom"} <= frames


def test_requests_the_trial_cannot_do_are_refused_by_name(tmp_path: Path) -> None:
    with pytest.raises(KeyError, match=r"no room 'attic'.*living_room"):
        run_carry(CarrySetup(to="attic"), 0, tmp_path)
    with pytest.raises(ValueError, match="room 'study' has no place"):
        run_carry(CarrySetup(to="study"), 0, tmp_path)
    with pytest.raises(ValueError, match="'bed' is furniture"):
        run_carry(CarrySetup(object="bed"), 0, tmp_path)
    with pytest.raises(KeyError, match="world 'room_a' has no body 'cup'"):
        run_carry(CarrySetup(world="room_a"), 0, tmp_path)


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
