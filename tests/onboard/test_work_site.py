"""Whether the mobile manipulator's arm gets to an object on a furniture top from a work
site facing it (onboard/skills.py, `Skills._reaches`): the grasp, the lift and, holding
it, the way back down, planned in the voxels of the top as the head camera sees it (its
top face and the face towards the robot). The robot itself does not run here: the
skills are asked with its arm in the stow pose; the carry trial runs the rest
(`robotrial bench chores`)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import ndimage

from robotrial.model import load_robot
from robotrial.onboard.catalogue import Catalogue, ObjectKind
from robotrial.onboard.skills import Held, Skills
from robotrial.onboard.voxels import SLAB_CELL
from robotrial.trials.nav_goals import _footprint

CAN = ObjectKind("can", "box", (0.07, 0.07, 0.07), (0.8, 0.1, 0.1))
EDGE_GAP = 0.05  # m from the base's front to the top's edge, as the map lets it stand


@pytest.fixture(scope="module")
def skills() -> Skills:
    model = load_robot("mobile_manipulator")
    stow = dict(model.metadata["poses"]["stow"])
    setup = SimpleNamespace(footprint=_footprint(), planner="rrt_connect", seed=0, grip_force=20)
    robot = SimpleNamespace(model=model, setup=setup, joints=stow)
    return Skills(robot, Catalogue([CAN]))  # type: ignore[arg-type]


def _top_seen(skills: Skills, height: float) -> None:
    """What the head camera makes of a top `height` high, 0.6 m deep and 2 m wide, its
    edge EDGE_GAP ahead of the base at the origin facing +x: its top face a slab, its
    front face voxels."""
    res = skills.voxels.resolution
    x0 = skills.footprint.length / 2 + EDGE_GAP
    ys = np.arange(-1.0, 1.0, res)
    front = np.stack(np.meshgrid([x0 + res / 2], ys, np.arange(0.05, height - res, res)), axis=-1)
    skills.voxels.keys = np.unique(np.floor(front.reshape(-1, 3) / res).astype(np.int64), axis=0)
    i = range(int(np.floor(x0 / SLAB_CELL)), int(np.floor((x0 + 0.6) / SLAB_CELL)))
    j = range(int(np.floor(-1.0 / SLAB_CELL)), int(np.floor(1.0 / SLAB_CELL)))
    skills.voxels.slabs = {(a, b): height for a in i for b in j}


@pytest.mark.parametrize("height", [0.75, 0.8])
def test_a_can_15_cm_in_from_the_edge_of_a_top_is_grasped_lifted_and_set_down(
    skills: Skills, height: float
) -> None:
    # the home generator puts objects 15 cm or more in from a top's edges; held level,
    # the wrist behind the hand meets the top beyond 5 cm in
    _top_seen(skills, height)
    base = np.zeros(3)
    can = np.array([skills.footprint.length / 2 + EDGE_GAP + 0.15, 0.0, height + 0.035])
    skills.held = None
    pitch = skills._reaches(base, can, CAN)
    assert pitch is not None
    back = CAN.grip_width / 2 + skills.palm
    skills.held = Held(CAN, np.array([0.0, 0.0, back]), CAN.grip_width, pitch)
    try:
        assert skills._reaches(base, can, CAN) == pitch
    finally:
        skills.held = None


def test_a_can_45_cm_in_on_a_counter_is_out_of_the_arm_s_reach(
    skills: Skills,
) -> None:
    _top_seen(skills, 0.9)
    can = np.array([skills.footprint.length / 2 + EDGE_GAP + 0.45, 0.0, 0.935])
    assert skills._reaches(np.zeros(3), can, CAN) is None


def test_a_work_site_is_offered_where_its_stage_has_no_room_to_turn(skills: Skills) -> None:
    # home 23's can stands 0.21 m in from a sofa's free side and 0.27 m from its end,
    # which is 0.3 m from a wall: a stage behind a site facing it is 0.57 m from that
    # wall, less than the footprint's turning circle
    from robotrial.benchmarks.chores import CHORE_HOMES
    from robotrial.model.gridmap import world_map
    from robotrial.model.homegen import generate_home

    world = generate_home(23, spec=CHORE_HOMES)
    grid = world_map(world, 0.025)
    skills.map_blocked = skills.map_walls = np.asarray(grid.occupied, dtype=bool)
    skills.map_origin, skills.map_res = np.asarray(grid.origin, dtype=float), grid.resolution
    skills.clearance = ndimage.distance_transform_edt(~skills.map_blocked) * grid.resolution
    can = next(o for o in world.objects if o.name == "can").pose.xyz
    sites = skills.base_candidates(np.array(can[:2]))
    assert sites
    for base, stage in sites:
        ahead = base[:2] - stage[:2]
        towards = np.array(can[:2]) - base[:2]
        assert np.dot(ahead, towards) > 0  # the stage is behind the site, facing the can
