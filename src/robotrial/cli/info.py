"""`robotrial info --robot R`: what a robot description holds, and what the loader
repaired.

Layer 5. R is a built-in robot name or a URDF / xacro / RDTF file. Prints the links,
the joints with their limits, total mass, degrees of freedom, the end effector, the
sensors and the repairs made while loading; `--json` prints the same as one object.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from typing import Any

from rich.console import Console

from robotrial.cli.robot_source import add_robot_source_arguments, load_robot_from_args
from robotrial.console import add_json_flag, print_json, print_table
from robotrial.model.anatomy import tool_choices
from robotrial.model.robot import ModelError, RobotModel

HELP = "show a robot's links, joints, mass, DOF, end effector, sensors and loader repairs"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_robot_source_arguments(parser, tool=True)
    add_json_flag(parser)


def summary(model: RobotModel) -> dict[str, Any]:
    """The facts `info` prints, as plain data."""
    joints = []
    for j in model.topological_joints():
        limit = None
        if j.limit is not None:
            limit = {
                "lower": j.limit.lower,
                "upper": j.limit.upper,
                "effort": j.limit.effort,
                "velocity": j.limit.velocity,
            }
        joints.append(
            {
                "name": j.name,
                "type": j.type,
                "parent": j.parent,
                "child": j.child,
                "axis": list(j.axis),
                "limit": limit,
                "mimic": None if j.mimic is None else j.mimic.joint,
            }
        )
    return {
        "name": model.name,
        "source": model.source,
        "root": model.root,
        "links": [
            {"name": lk.name, "mass": lk.inertial.mass if lk.inertial else 0.0}
            for lk in model.links
        ],
        "joints": joints,
        "dof": len(model.actuated_joints),
        "actuated_joints": model.joint_names,
        "total_mass": model.total_mass,
        "end_effector": model.end_effector,
        "tcp": model.tcp,
        "tool_links": tool_choices(model),
        "sensors": [
            {"name": s.name, "type": s.type, "link": s.link, "rate_hz": s.rate_hz}
            for s in model.sensors
        ],
        "spheres": len(model.spheres),
        "metadata": dict(model.metadata),
        "repairs": list(model.repairs),
    }


def _limit_text(value: float | None, jtype: str) -> str:
    if value is None or jtype == "continuous":
        return "-"
    return f"{value:.4g}"


def run(args: argparse.Namespace) -> int:
    try:
        with warnings.catch_warnings():
            # repairs are listed in the output; the loader's warnings would repeat them
            warnings.simplefilter("ignore")
            model = load_robot_from_args(args)
    except (ModelError, ValueError, OSError, KeyError) as exc:
        msg = " ".join(str(exc).split())
        print(f"robotrial info: error: {msg}", file=sys.stderr)
        return 1
    info = summary(model)
    if args.json:
        print_json(info)
        return 0
    out = Console()
    out.print(f"[bold]{model.name}[/bold]  ({model.source or args.robot})")
    out.print(
        f"links {len(model.links)}, joints {len(model.joints)}, DOF {info['dof']}, "
        f"total mass {model.total_mass:.4g} kg, root {model.root}, "
        f"end effector {model.end_effector}"
    )
    print_table(
        "links",
        ("link", "mass (kg)", "visuals", "collisions"),
        [
            (lk.name, lk.inertial.mass if lk.inertial else 0.0, len(lk.visuals), len(lk.collisions))
            for lk in model.links
        ],
    )
    rows = []
    for j in info["joints"]:
        lim = j["limit"] or {}
        rows.append(
            (
                j["name"],
                j["type"] + (f" (mimics {j['mimic']})" if j["mimic"] else ""),
                j["parent"],
                j["child"],
                _limit_text(lim.get("lower"), j["type"]),
                _limit_text(lim.get("upper"), j["type"]),
            )
        )
    if rows:
        print_table("joints", ("joint", "type", "parent", "child", "lower", "upper"), rows)
    if model.sensors:
        print_table(
            "sensors",
            ("sensor", "type", "link", "rate (Hz)"),
            [(s.name, s.type, s.link, s.rate_hz) for s in model.sensors],
        )
    if info["tool_links"]:
        out.print(f"tool links (--tool): {', '.join(info['tool_links'])}")
    for key, value in model.metadata.items():
        out.print(f"{key}: {value}")
    if model.repairs:
        out.print(f"[yellow]repairs made while loading ({len(model.repairs)}):[/yellow]")
        for r in model.repairs:
            out.print(f"  - {r}", markup=False, highlight=False)
    else:
        out.print("repairs: none")
    return 0
