"""Whether the mobile manipulator's arm gets to an object on a furniture top from a work
site facing it (onboard/skills.py, `Skills._reaches`): the grasp, the lift and, holding
it, the way back down, planned in the voxels of the top as the head camera sees it (its
top face and the face towards the robot). The robot itself does not run here: the
skills are asked with its arm in the stow pose; the carry trial runs the rest
(`robotrial bench chores`); `robotrial bench reach` measures how far in the arm
takes objects from tops of each height, the torso lift at each of its heights."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from robotrial.benchmarks.reach import EDGE_GAP, skills_at_stow, takes_and_sets_down
from robotrial.onboard.catalogue import ObjectKind
from robotrial.onboard.skills import REACHES, Skills

CAN = ObjectKind("can", "box", (0.07, 0.07, 0.07), (0.8, 0.1, 0.1))


@pytest.fixture(scope="module")
def skills() -> Skills:
    return skills_at_stow("mobile_manipulator", [CAN])


def _edge_gap(skills: Skills, inward: float, reach: float) -> float:
    """How far the base's front stands off the top's edge (m) with the object `inward`
    in from it and `reach` ahead of the arm's base."""
    return skills.arm_offset + reach - inward - skills.footprint.length / 2


@pytest.mark.parametrize(
    ("height", "inward", "reach"), [(0.75, 0.4, 0.6), (0.8, 0.4, 0.6), (0.9, 0.3, 0.55)]
)
def test_a_can_30_cm_or_more_in_from_a_top_s_edge_is_grasped_lifted_and_set_down(
    skills: Skills, height: float, inward: float, reach: float
) -> None:
    # the home generator puts objects 15-53 cm in from a top's edges; the arm on its
    # riser takes them from a work site the skills offer, the base off the edge
    assert reach in REACHES and _edge_gap(skills, inward, reach) >= EDGE_GAP
    assert takes_and_sets_down(skills, CAN, height, inward, reach)


def test_a_can_is_taken_from_and_set_down_on_a_bed_with_the_lift_lowered(skills: Skills) -> None:
    # a bed 0.5 m high, the place 12 cm in from its edge (as a home's place): held
    # level, the arm with its shoulder 0.75 m up cannot set it down there
    way = takes_and_sets_down(skills, CAN, 0.5, 0.12, 0.5)
    assert way is not None and way.lift == 0.0


def test_a_can_45_cm_in_on_a_counter_is_taken_with_the_lift_raised(skills: Skills) -> None:
    # homes put cans 0.40-0.45 m in on 0.9 m counters; the lift lowered, the arm's
    # shoulder 0.75 m up, it takes them no further in than 0.30 m
    assert 0.65 in REACHES and _edge_gap(skills, 0.45, 0.65) >= EDGE_GAP
    way = takes_and_sets_down(skills, CAN, 0.9, 0.45, 0.65)
    assert way is not None and way.lift > 0.0
    lifts, skills.lifts = skills.lifts, (0.0,)
    try:
        assert takes_and_sets_down(skills, CAN, 0.9, 0.45, 0.65) is None
    finally:
        skills.lifts = lifts


def test_a_can_50_cm_in_on_a_table_is_out_of_the_arm_s_reach(skills: Skills) -> None:
    assert _edge_gap(skills, 0.5, 0.7) >= EDGE_GAP
    assert not takes_and_sets_down(skills, CAN, 0.75, 0.5, 0.7)


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
