"""The held object's pose in the hand from what the head camera sees of it
(onboard/held.py): a cup turned in a pitched grasp, its sides and top seen from the
head, is fitted back; the hand is pitched so that it is set down upright."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from robotrial.onboard.catalogue import ObjectKind
from robotrial.onboard.held import bottom, fit_held, lowest, upright_pitch
from robotrial.onboard.skills import SIDE_GRASP, Held

CUP = ObjectKind("cup", "cylinder", (0.06, 0.06, 0.1), (0.95, 0.95, 0.95))
CAMERA = np.array([0.1, 0.0, 1.35])  # the head, behind and above the hand (base frame)
PITCH = np.deg2rad(30.0)


def _hand(pitch: float) -> np.ndarray:
    """The tool's pose (4x4, base frame) of a side grasp pitched down by `pitch`, 0.6 m
    ahead at 0.9 m."""
    tcp = np.eye(4)
    tcp[:3, :3] = (Rotation.from_euler("y", pitch) * SIDE_GRASP).as_matrix()
    tcp[:3, 3] = (0.6, 0.0, 0.9)
    return tcp


def _seen(kind: ObjectKind, pose: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Points of a cylinder's surface (base frame) that face the camera, with the head
    depth camera's 5 mm of noise."""
    r, h = kind.width / 2, kind.height
    a, z = np.meshgrid(
        np.linspace(0, 2 * np.pi, 72, endpoint=False), np.linspace(-h / 2, h / 2, 25)
    )
    side = np.column_stack([r * np.cos(a.ravel()), r * np.sin(a.ravel()), z.ravel()])
    side_n = np.column_stack([np.cos(a.ravel()), np.sin(a.ravel()), np.zeros(a.size)])
    rr, aa = np.meshgrid(np.linspace(0, r, 8), np.linspace(0, 2 * np.pi, 36, endpoint=False))
    top = np.column_stack(
        [(rr * np.cos(aa)).ravel(), (rr * np.sin(aa)).ravel(), np.full(rr.size, h / 2)]
    )
    top_n = np.tile([0.0, 0.0, 1.0], (len(top), 1))
    local, normals = np.vstack([side, top]), np.vstack([side_n, top_n])
    pts = local @ pose[:3, :3].T + pose[:3, 3]
    facing = np.einsum("ij,ij->i", normals @ pose[:3, :3].T, CAMERA - pts) > 0
    return pts[facing] + rng.normal(0.0, 0.005, (int(facing.sum()), 3))


@pytest.mark.parametrize("turn", [-12.0, 9.0, 21.0])
def test_a_cup_turned_in_a_pitched_grasp_is_measured_from_its_sides_and_top(turn: float) -> None:
    # the apartment's cup turned 8.5-21 degrees about the fingers' line and sat 1-2.4
    # cm further out along the approach than the grasp put it
    tcp = _hand(PITCH)
    believed = Held(CUP, np.array([0.0, 0.0, 0.045]), CUP.grip_width, PITCH)
    assert believed.rotation is not None
    c, s = np.cos(np.deg2rad(turn)), np.sin(np.deg2rad(turn))
    true_rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ believed.rotation
    true_centre = believed.in_hand + np.array([-0.006, 0.0, 0.024])
    pose = np.eye(4)
    pose[:3, :3] = tcp[:3, :3] @ true_rot
    pose[:3, 3] = tcp[:3, :3] @ true_centre + tcp[:3, 3]
    rng = np.random.default_rng(0)
    pts = _seen(CUP, pose, rng)
    stray = pose[:3, 3] + rng.uniform(-0.05, 0.05, (15, 3))  # a finger's edge, the table
    fit = fit_held(np.vstack([pts, stray]), CUP, tcp, believed.rotation, believed.in_hand)
    assert fit is not None
    assert abs(np.rad2deg(fit.turn) - turn) < 2.0
    assert np.linalg.norm(fit.centre - true_centre) < 0.003
    # set down with the hand pitched so, the cup stands upright and its lowest point is
    # its bottom's middle, half its height below its centre
    pitch = upright_pitch(fit.rotation, SIDE_GRASP.as_matrix())
    held = (Rotation.from_euler("y", pitch) * SIDE_GRASP).as_matrix() @ fit.rotation
    assert np.rad2deg(np.arccos(min(held[2, 2], 1.0))) < 0.5
    assert lowest(CUP, held) == pytest.approx(CUP.height / 2, abs=1e-4)
    assert np.allclose(bottom(CUP, held), [0.0, 0.0, -CUP.height / 2], atol=1e-4)


def test_too_few_points_of_the_held_object_give_no_fit() -> None:
    believed = Held(CUP, np.array([0.0, 0.0, 0.045]), CUP.grip_width, PITCH)
    assert believed.rotation is not None
    pts = np.array([[0.65, 0.0, 0.95]] * 10)
    assert fit_held(pts, CUP, _hand(PITCH), believed.rotation, believed.in_hand) is None


def test_a_cup_let_go_tilted_lands_on_its_rim_below_its_centre() -> None:
    # tilted 20 degrees, the cup's lowest point is on its bottom's rim: 5 cm of half
    # height times cos 20 plus 3 cm of radius times sin 20 below its centre
    tilt = Rotation.from_euler("y", np.deg2rad(20.0)).as_matrix()
    want = 0.05 * np.cos(np.deg2rad(20.0)) + 0.03 * np.sin(np.deg2rad(20.0))
    assert lowest(CUP, tilt) == pytest.approx(want, abs=1e-6)
    assert bottom(CUP, tilt)[0] == pytest.approx(-0.05 * np.sin(np.deg2rad(20.0)), abs=1e-6)


def test_a_box_seen_on_the_face_a_finger_holds_keeps_the_turn_it_was_believed_to_have() -> None:
    # home 31: the 7 cm cube shown to the camera on the face its finger holds, its
    # outline hidden (the finger, the pixels at its edges), and a strip of its back; that
    # face lies in the same plane at every turn about the fingers' line
    can = ObjectKind("can", "box", (0.07, 0.07, 0.07), (0.75, 0.72, 0.68))
    tcp = _hand(0.0)
    believed = Held(can, np.array([0.0, 0.0, 0.04]), can.grip_width, 0.0)
    assert believed.rotation is not None
    c, s = np.cos(np.deg2rad(8.0)), np.sin(np.deg2rad(8.0))
    pose = np.eye(4)
    pose[:3, :3] = (
        tcp[:3, :3] @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ believed.rotation
    )
    pose[:3, 3] = tcp[:3, :3] @ believed.in_hand + tcp[:3, 3]
    u = np.linspace(-0.025, 0.025, 18)
    a, b = (g.ravel() for g in np.meshgrid(u, u))
    side = np.column_stack([a, np.full_like(a, -0.035), b])  # the face towards the camera
    back = np.column_stack([np.full(8, -0.035), np.linspace(-0.035, -0.025, 8), np.zeros(8)])
    rng = np.random.default_rng(1)
    pts = np.vstack([side, back]) @ pose[:3, :3].T + pose[:3, 3]
    pts += rng.normal(0.0, 0.005, pts.shape)
    fit = fit_held(pts, can, tcp, believed.rotation, believed.in_hand)
    assert fit is None or fit.turn == 0.0
