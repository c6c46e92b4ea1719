"""What a robot's parts are when its description does not say: the arm's joints and its
tool link, the gripper's fingers, the base's wheels (layer 1).

A URDF written for ROS names none of these: MoveIt learns them from an SRDF that a person
writes with the Setup Assistant. A buyer's file has no SRDF, so they are read from the
kinematic tree:

- finger joints: joints that mimic another or are mimicked, joints named like a finger or
  a gripper (finger, gripper, thumb, knuckle, jaw, claw, hand), and every joint below one;
- wheel joints: continuous joints with a level axis (at the zero pose, in the root's
  frame) named like a wheel or a caster, or turning a link with a round collision shape
  and nothing moving below it;
- the arm: the longest chain from the root counted in driven joints that are neither;
- the tool link: among the links fixed to the arm's last link, the one named most like a
  tool frame (tcp, then grasp, tool, end effector, flange, tip; the deeper one on a tie),
  else the deepest one.

`completed(model)` fills `tcp`, the `arm` group and the gripper where the description
gives none; `with_tool(model, link)` makes another link the tool and the arm the chain
that moves it (`--tool LINK`, the page's tool choice).
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from robotrial.geometry import Cylinder, Sphere
from robotrial.model.robot import ModelError, RobotModel

FINGER_WORDS = re.compile(r"finger|gripper|thumb|knuckle|jaw|claw|hand", re.IGNORECASE)
WHEEL_WORDS = re.compile(r"wheel|caster", re.IGNORECASE)
# how much a word in a link's name says "this is the tool frame", best first
TOOL_WORDS: tuple[tuple[str, int], ...] = (
    ("tcp", 6),
    ("grasp", 5),
    ("grasping", 5),
    ("tool", 4),
    ("tool0", 4),
    ("ee", 3),
    ("eef", 3),
    ("endeffector", 3),
    ("flange", 2),
    ("tip", 1),
)
MIN_ARM_JOINTS = 2  # a chain of fewer driven joints is not an arm
LEVEL = 0.5  # a wheel's axis has at most this much of its length along the root's z


def _words(name: str) -> list[str]:
    """The words of a link name: split at non-letters and at lower-to-upper case steps,
    "end_effector" also read as one word."""
    spaced = re.sub(r"([a-z0-9])([A-Z])", r"\1 \2", name)
    words = [w.lower() for w in re.split(r"[^A-Za-z0-9]+", spaced) if w]
    joined = [a + b for a, b in itertools.pairwise(words)]
    return words + joined


def tool_score(name: str) -> int:
    """How much a link's name says it is a tool frame (0: not at all)."""
    scores = dict(TOOL_WORDS)
    return max((scores.get(w, 0) for w in _words(name)), default=0)


def finger_joints(model: RobotModel) -> set[str]:
    """Joints of the robot's hands: mimic joints and the joints they follow, joints named
    like fingers, and every joint below one of them."""
    mimicked = {j.mimic.joint for j in model.joints if j.mimic is not None}
    out: set[str] = set()
    for j in model.topological_joints():
        above = model.parent_joint(j.parent)
        moving = j.type in ("revolute", "continuous", "prismatic")
        if (above is not None and above.name in out) or (
            moving and (j.mimic is not None or j.name in mimicked or FINGER_WORDS.search(j.name))
        ):
            out.add(j.name)
    return out


def wheel_joints(model: RobotModel) -> list[str]:
    """Continuous joints that turn a wheel: their axis level at the zero pose, and named
    like a wheel, or turning a round link (a cylinder or sphere collision) below which
    nothing moves. Tree order."""
    out = []
    frames = _zero_frames(model)
    for j in model.topological_joints():
        if j.type != "continuous" or j.mimic is not None:
            continue
        axis = frames[j.parent][:3, :3] @ j.origin.matrix()[:3, :3] @ np.asarray(j.axis)
        if abs(axis[2]) > LEVEL * np.linalg.norm(axis):
            continue
        if WHEEL_WORDS.search(j.name) or WHEEL_WORDS.search(j.child):
            out.append(j.name)
            continue
        link = model.link(j.child)
        round_ = bool(link.collisions) and all(
            isinstance(c.geometry, Cylinder | Sphere) for c in link.collisions
        )
        if round_ and not _moves_below(model, j.child):
            out.append(j.name)
    return out


def _zero_frames(model: RobotModel) -> dict[str, np.ndarray]:
    """Every link's pose in the root's frame with all joints at zero."""
    out = {model.root: np.eye(4)}
    for j in model.topological_joints():
        out[j.child] = out[j.parent] @ j.origin.matrix()
    return out


def has_wheels(model: RobotModel) -> bool:
    """Whether the tree has a wheeled base (at least two wheel joints)."""
    return len(wheel_joints(model)) >= 2


def base_links(model: RobotModel) -> list[str]:
    """The links of the mobile base: those no driven joint moves but wheels (and what
    turns with a wheel). Tree order, the root first."""
    wheels = set(wheel_joints(model))
    out = [model.root]
    for j in model.topological_joints():
        if j.parent in out and (j.type == "fixed" or j.name in wheels):
            out.append(j.child)
    return out


def _moves_below(model: RobotModel, link: str) -> bool:
    stack = [link]
    while stack:
        for j in model.child_joints(stack.pop()):
            if j.type != "fixed":
                return True
            stack.append(j.child)
    return False


def _arm_joints_to(model: RobotModel, link: str, skip: set[str]) -> list[str]:
    return [j.name for j in model.chain(link) if j.actuated and j.name not in skip]


def arm_joints(model: RobotModel, tool: str = "") -> list[str]:
    """The driven joints that move `tool` (default: the tool `find_tool` names), fingers
    and wheels left out; [] for a robot without an arm."""
    tool = tool or find_tool(model)
    if not tool:
        return []
    return _arm_joints_to(model, tool, finger_joints(model) | set(wheel_joints(model)))


def _last_arm_link(model: RobotModel, skip: set[str]) -> str:
    """The link the longest arm chain ends on (the child of its last driven joint); ""
    when no chain has MIN_ARM_JOINTS driven joints. The first in tree order on a tie."""
    best, count = "", MIN_ARM_JOINTS - 1
    for j in model.topological_joints():
        if not j.actuated or j.name in skip:
            continue
        n = len(_arm_joints_to(model, j.child, skip))
        if n > count:
            best, count = j.child, n
    return best


def _rigid_below(model: RobotModel, link: str) -> list[tuple[str, int]]:
    """`link` and the links fixed to it (through fixed joints only), with their depth."""
    out, stack = [], [(link, 0)]
    while stack:
        name, depth = stack.pop(0)
        out.append((name, depth))
        stack += [(j.child, depth + 1) for j in model.child_joints(name) if j.type == "fixed"]
    return out


def find_tool(model: RobotModel) -> str:
    """The tool link: the description's `tcp`, else the link fixed to the end of the
    longest arm chain that is named most like a tool frame (see the module doc); "" for
    a robot without an arm."""
    if model.tcp:
        return model.tcp
    skip = finger_joints(model) | set(wheel_joints(model))
    last = _last_arm_link(model, skip)
    if not last:
        return ""
    fixed = _rigid_below(model, last)
    return max(fixed, key=lambda item: (tool_score(item[0]), item[1]))[0]


def tool_choices(model: RobotModel) -> list[str]:
    """Links that may serve as the tool: every link that at least MIN_ARM_JOINTS driven
    joints (fingers and wheels left out) move, in tree order; the tool first."""
    skip = finger_joints(model) | set(wheel_joints(model))
    order = [model.root] + [j.child for j in model.topological_joints()]
    fingers = {j.child for j in model.joints if j.name in skip}
    links = [
        name
        for name in order
        if name not in fingers and len(_arm_joints_to(model, name, skip)) >= MIN_ARM_JOINTS
    ]
    tool = find_tool(model)
    return ([tool] if tool in links else []) + [n for n in links if n != tool]


def _gripper(model: RobotModel, last: str, fingers: set[str]) -> dict[str, Any] | None:
    """The fingers below the arm's last link as `metadata["gripper"]`: the driven ones,
    open at the limit farther from zero, closed at the one nearer."""
    below = {name for name, _ in _rigid_below(model, last)}
    stack, moving = list(below), []
    seen = set(below)
    while stack:
        for j in model.child_joints(stack.pop()):
            if j.name in fingers and j.actuated:
                moving.append(j)
            if j.child not in seen:
                seen.add(j.child)
                stack.append(j.child)
    if not moving:
        return None
    first = moving[0]
    lo, hi = (first.limit.lower, first.limit.upper) if first.limit else (0.0, 0.0)
    open_, closed = (hi, lo) if abs(hi) >= abs(lo) else (lo, hi)
    return {
        "joints": [j.name for j in moving],
        "open": float(open_),
        "closed": float(closed),
        "link": last,
    }


def completed(model: RobotModel) -> RobotModel:
    """`model` with what the tree tells filled in where the description is silent: the
    tool link as `tcp`, the `arm` group, the gripper. A robot without an arm comes back
    unchanged."""
    tool = find_tool(model)
    if not tool:
        return model
    skip = finger_joints(model) | set(wheel_joints(model))
    metadata: dict[str, Any] = dict(model.metadata)
    groups: Mapping[str, Any] = metadata.get("groups") or {}
    if "arm" not in groups:
        metadata["groups"] = {**groups, "arm": _arm_joints_to(model, tool, skip)}
    if "gripper" not in metadata:
        last = model.chain(tool)
        driven = [j for j in last if j.actuated and j.name not in skip]
        grip = _gripper(model, driven[-1].child, skip) if driven else None
        if grip is not None:
            metadata["gripper"] = grip
    return model.with_changes(tcp=tool, metadata=metadata)


def with_tool(model: RobotModel, link: str) -> RobotModel:
    """`model` with `link` as its tool and the chain of driven joints that moves it as
    the `arm` group (fingers and wheels left out). ModelError, naming the links one may
    choose, when `link` is not one of `tool_choices`."""
    choices = tool_choices(model)
    if link not in choices:
        known = {lk.name for lk in model.links}
        why = "is not a link of the robot" if link not in known else "is not moved by an arm"
        shown = ", ".join(choices[:12]) + (", ..." if len(choices) > 12 else "")
        raise ModelError(
            f"robot {model.name!r}: tool link {link!r} {why}; choose one of: {shown or 'none'}"
        )
    skip = finger_joints(model) | set(wheel_joints(model))
    metadata = dict(model.metadata)
    groups = dict(metadata.get("groups") or {})
    metadata["groups"] = {**groups, "arm": _arm_joints_to(model, link, skip)}
    return model.with_changes(tcp=link, metadata=metadata)


__all__ = [
    "arm_joints",
    "base_links",
    "completed",
    "find_tool",
    "finger_joints",
    "has_wheels",
    "tool_choices",
    "tool_score",
    "wheel_joints",
    "with_tool",
]
