"""`robotrial verdict --world W --robot R`: will this robot get around this home (layer 5).

Which rooms the robot's base reaches from the dock with its real footprint, and how tight
the way is (robotrial.trials.verdict). Prints the summary and a table; `-o` writes the
figures as JSON, `--html` one printable page with the floor plan, `--plot` the picture.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from robotrial.console import add_json_flag, console, print_json, print_table

HELP = "will a robot get around a home: rooms reachable from the dock, tight passages"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", required=True, help="built-in world name or World YAML")
    parser.add_argument(
        "--robot", default="mobile_manipulator", help="built-in robot name or a robot file"
    )
    parser.add_argument("-o", "--output", type=Path, help="write the figures as JSON here")
    parser.add_argument("--html", type=Path, help="write one printable page here")
    parser.add_argument("--plot", type=Path, metavar="PNG", help="write the floor plan here")
    add_json_flag(parser)


def run(args: argparse.Namespace) -> int:
    from robotrial.model import ModelError, load_world
    from robotrial.trials.nav import footprint_of_robot
    from robotrial.trials.verdict import check_base, plot, to_html

    try:
        world = load_world(args.world)
        footprint = footprint_of_robot(args.robot, world)
        verdict = check_base(world, footprint, args.robot)
    except (ModelError, KeyError, FileNotFoundError, ValueError) as exc:
        console.print(f"[red]robotrial verdict:[/red] {exc}")
        return 2
    report = verdict.to_dict()
    if args.output:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(json.dumps(report, indent=2))
    if args.html or args.plot:
        picture = plot(verdict, world, args.plot)
        if args.html:
            args.html.parent.mkdir(parents=True, exist_ok=True)
            args.html.write_text(to_html(verdict, picture))
    if args.json:
        print_json(report)
        return 0
    console.print(f"[bold]{verdict.summary}[/bold] ({verdict.seconds:.2f} s)")
    print_table(
        f"{args.robot} in {world.name}",
        ["room", "verdict", "narrowest passage (m)", "route (m)", "why not"],
        [
            [
                r.room,
                r.colour,
                "" if r.passage is None else f"{r.passage:.2f}",
                "" if r.route_length is None else f"{r.route_length:.1f}",
                r.reason,
            ]
            for r in verdict.rooms
        ],
    )
    return 0
