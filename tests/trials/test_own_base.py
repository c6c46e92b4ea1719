"""A mobile base of the user's own: pybullet_data's Husky, whose URDF names no drive,
gets the verdict's rooms-and-passages part, its footprint measured from its collision
geometry."""

from __future__ import annotations

import warnings
from pathlib import Path

import pybullet_data

from robotrial.model import load_robot
from robotrial.trials.verdict import check_home, has_base


def test_husky_of_pybullet_data_gets_the_rooms_part() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        husky = load_robot(Path(pybullet_data.getDataPath()) / "husky" / "husky.urdf")
    assert not husky.metadata.get("drive") and has_base(husky)
    verdict = check_home("apartment", husky)
    length, width = verdict.base.footprint
    # its bumpers and wheels: about the 0.99 x 0.67 m of a real Husky
    assert 0.9 < length < 1.1 and 0.6 < width < 0.75, verdict.base.footprint
    assert verdict.base.rooms and all(r.reachable for r in verdict.base.rooms)
    assert "no arm" in verdict.reach.summary
