"""map_server files: round trip, the CLI's outputs load back, bad files are refused."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from robotrial.cli import main
from robotrial.model import ModelError
from robotrial.model.mapfile import OccupancyMap, read_map, write_map


def test_round_trip(tmp_path):
    data = np.full((4, 6), -1, np.int8)
    data[0, :] = 100
    data[1:3, 1:5] = 0
    m = OccupancyMap(data, 0.05, (-1.0, -2.0, 0.0))
    pgm, yml = write_map(tmp_path / "m", m)
    assert pgm.read_bytes().startswith(b"P5")
    meta = yaml.safe_load(yml.read_text())
    assert meta["image"] == "m.pgm" and meta["resolution"] == 0.05
    back = read_map(yml)
    assert np.array_equal(back.data, data)
    assert back.origin == (-1.0, -2.0, 0.0) and back.resolution == 0.05


def test_image_top_row_is_the_highest_y(tmp_path):
    data = np.zeros((3, 2), np.int8)
    data[2, :] = 100
    pgm, _ = write_map(tmp_path / "m", OccupancyMap(data, 0.1))
    from PIL import Image

    with Image.open(pgm) as im:
        assert np.asarray(im)[0].tolist() == [0, 0]


def test_refuses_incomplete_yaml(tmp_path):
    (tmp_path / "bad.yaml").write_text("image: x.pgm\n")
    with pytest.raises(ModelError, match="resolution"):
        read_map(tmp_path / "bad.yaml")


def test_cli_writes_map_trajectory_and_plot(room_b_bag, tmp_path, capsys):
    out = tmp_path / "room_b"
    assert (
        main(["slam", "--method", "hector", "--bag", str(room_b_bag), "-o", str(out), "--json"])
        == 0
    )
    result = json.loads(capsys.readouterr().out)
    assert result["world"] == "room_b" and result["room"]["error"] < 0.05
    m = read_map(out.with_suffix(".yaml"))
    assert (m.data == 100).sum() > 500 and (m.data == 0).sum() > 10000
    rows = np.loadtxt(out.with_suffix(".tum"))
    assert rows.shape[1] == 8 and len(rows) == result["scans"]
    assert out.with_suffix(".png").stat().st_size > 10000


def test_cli_gmapping_without_odom_fails_clearly(no_odom_bag, tmp_path, capsys):
    code = main(
        ["slam", "--method", "gmapping", "--bag", str(no_odom_bag), "-o", str(tmp_path / "x")]
    )
    assert code == 2
    assert "/odom" in capsys.readouterr().err
