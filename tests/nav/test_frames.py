"""One frame from SLAM to navigation: a map `robotrial slam` made from a `robotrial sim`
recording is navigated as it is, with the goal in the map's own frame, in rooms A, B, C
and the apartment. The robot's start on the map comes from the map's metadata, or, on a
map that says nothing of its frame, from AMCL's global localization. The test puts the
goal in the world itself (the recording began at the world's spawn, where the map frame
lies) and checks where the simulated robot truly stops. A map whose frame the navigation
took for the world's would stop it a metre or more away."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from robotrial.cli import main
from robotrial.model import load_world
from robotrial.nav.amcl import compose

# goals on the map (x, y, yaw in the frame of the robot's pose when mapping began),
# where the scan from the spawn sees free floor all round the base
GOALS = {
    "room_a": (2.5, 1.5, 0.5),
    "room_b": (2.0, -0.2, 1.2),
    "room_c": (2.5, 1.2, 0.0),
    "apartment": (0.0, -1.3, -1.57),
}


def _map(world: str, tmp_path, capsys) -> Path:
    """The stem of a map `robotrial slam` made from a 2 s recording at the spawn."""
    bag, stem = tmp_path / "run.mcap", tmp_path / "mymap"
    args = ["sim", "--world", world, "--duration", "2", "--drive", "none"]
    assert main([*args, "--record", str(bag), "--plot", str(tmp_path / "sim.png")]) == 0
    argv = ["slam", "--method", "gmapping", "--bag", str(bag), "-o", str(stem), "--world", world]
    assert main([*argv, "--json"]) == 0
    capsys.readouterr()
    return stem


def _navigate(world: str, stem: Path, capsys) -> dict:
    """`robotrial nav` on the map to the world's goal; its JSON, checked for where the
    simulated robot truly stopped."""
    goal = GOALS[world]
    argv = ["nav", "--world", world, "--map", f"{stem}.yaml", "--speed", "1.0", "--json"]
    code = main([*argv, "--goal", *map(str, goal)])
    out = json.loads(capsys.readouterr().out)
    run = out["runs"][0]
    spawn = load_world(world).spawn("default")
    target = compose(np.array([*spawn.xyz[:2], spawn.yaw]), np.array(goal))
    off = float(np.hypot(*(np.array(run["end"][:2]) - target[:2])))
    assert code == 0 and run["success"], run
    assert off <= 0.15, f"stopped {off:.2f} m from the goal in the world: {run}"
    return out


@pytest.mark.parametrize("world", list(GOALS))
def test_a_map_made_by_slam_is_navigated_in_its_own_frame(world, tmp_path, capsys):
    out = _navigate(world, _map(world, tmp_path, capsys), capsys)
    assert out["start_from"] == "the map's metadata"
    assert np.allclose(out["start"], (0.0, 0.0, 0.0), atol=1e-6)


def test_a_map_with_no_frame_is_navigated_after_global_localization(tmp_path, capsys):
    """A map_server map that says nothing of where it lies: AMCL spreads its particles over
    the whole free space, gathers them while the robot turns, and the goal in the map's
    frame is reached."""
    stem = _map("room_b", tmp_path, capsys)
    meta = yaml.safe_load(stem.with_suffix(".yaml").read_text())
    meta.pop("robotrial")
    stem.with_suffix(".yaml").write_text(yaml.safe_dump(meta))
    assert _navigate("room_b", stem, capsys)["start_from"] == "global localization"
