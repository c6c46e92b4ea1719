"""The parallel gripper holds by friction alone (sim/controllers.py `Gripper`, the contact
settings of sim/build.py), in the small scene of `robotrial bench grasp`: the robot's own
hand on slides, a table, one object."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from robotrial.benchmarks.grasp import grasp_once, hand_robot
from robotrial.model import load_world


@pytest.fixture(scope="module")
def hand():
    return hand_robot()


def objects() -> dict:
    return {o.name: o for o in load_world("apartment").objects}


def test_the_cup_is_held_by_the_squeeze_and_its_friction(hand) -> None:
    """Closed with 20 N on a cup it was aimed 5 mm beside, the hand lifts it and drives
    it back and forth at 1 m/s^2; the cup barely moves in the hand."""
    held = grasp_once(*hand, objects()["cup"], 20.0, 0.005, np.random.default_rng(0))
    assert held["held"], held
    assert held["slip_mm"] < 3.0 and held["tilt_deg"] < 3.0, held


def test_a_weak_squeeze_lets_the_can_slip_out(hand) -> None:
    """1 N per finger holds at most 2 N by friction (coefficient 1): the 0.35 kg can
    weighs 3.4 N and slides out when lifted; nothing holds it but the contacts."""
    dropped = grasp_once(*hand, objects()["can"], 1.0, 0.0, np.random.default_rng(0))
    assert not dropped["held"], dropped


def test_the_fingers_stop_on_the_object_and_push_with_the_force_asked(hand) -> None:
    """The fingers close until they stand on the can (its 6.6 cm diameter) and push
    with the 15 N asked; no weld or attachment exists in the model, only the fingers'
    mimic coupling."""
    from robotrial.sim import Simulation

    got = grasp_once(*hand, objects()["can"], 15.0, 0.0, np.random.default_rng(1))
    assert got["closed_on_mm"] == pytest.approx(66.0, abs=1.5)
    assert got["squeeze_n"] == pytest.approx(15.0, rel=0.02)
    sim = Simulation.create("apartment", "mobile_manipulator")
    m = sim.world.model
    assert m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert [m.eq(i).name for i in range(m.neq)] == ["mimic/arm_finger_right"]
    sim.close()
