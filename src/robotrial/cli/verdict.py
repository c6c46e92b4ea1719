"""`robotrial verdict --world W --robot R [--robot R2]`: will this robot get around this
home, what does its arm reach, can it do the chores (layer 5).

The engine is robotrial.trials.verdict (`check_home`, `compare`). Prints the summary and a
table (one column per robot when two are given); `-o` writes the figures as JSON, `--html`
one printable page, `--page` the same on one sheet as PDF or PNG, `--plot` the floor plan.
`--chore cup:bedroom` runs that chore as carry trials over `--seeds` seeds (slow: about a
minute of CPU per run).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from robotrial.console import add_json_flag, console, print_json, print_table, progress

HELP = "will a robot get around a home: rooms, reach over the furniture, chores; two side by side"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", required=True, help="built-in world name or World YAML")
    parser.add_argument(
        "--robot",
        action="append",
        help="built-in robot name or a robot file (default mobile_manipulator); give it "
        "twice to compare two robots",
    )
    parser.add_argument(
        "--chore",
        action="append",
        default=[],
        metavar="OBJECT:ROOM",
        help="a task to run as the carry trial, e.g. cup:bedroom, or cup@kitchen_table:bedroom "
        "naming the furniture the cup should be on (repeatable; slow)",
    )
    parser.add_argument("--seeds", type=int, default=3, help="runs per chore (default 3)")
    parser.add_argument("-o", "--output", type=Path, help="write the figures as JSON here")
    parser.add_argument("--html", type=Path, help="write one printable page here")
    parser.add_argument("--page", type=Path, help="write the page on one sheet (.pdf or .png)")
    parser.add_argument("--plot", type=Path, metavar="PNG", help="write the floor plan here")
    add_json_flag(parser)


def _fail(message: object) -> int:
    console.print(f"[red]robotrial verdict:[/red] {message}")
    return 2


def run(args: argparse.Namespace) -> int:
    from robotrial.model import ModelError, load_world
    from robotrial.trials.chores import parse_chore
    from robotrial.trials.verdict import check_home, compare, pictures, to_html, write_page

    robots = args.robot or ["mobile_manipulator"]
    if len(robots) > 2:
        return _fail(f"compare at most two robots at a time, got {len(robots)}")
    if args.page is not None and args.page.suffix.lower() not in (".pdf", ".png"):
        return _fail(f"--page {args.page}: write it as .pdf or .png")
    verdicts = []
    try:
        chores = [parse_chore(c) for c in args.chore]
        world = load_world(args.world)
        for name in robots:
            with progress(f"verdict: {name}", 100.0, enabled=not args.json) as advance:
                done = [0.0]

                def tell(fraction: float, what: str, done=done, advance=advance) -> None:
                    advance(max(0.0, 100.0 * fraction - done[0]))
                    done[0] = max(done[0], 100.0 * fraction)

                verdicts.append(
                    check_home(world, name, chores=chores, seeds=args.seeds, progress=tell)
                )
    except (ModelError, KeyError, FileNotFoundError, ValueError) as exc:
        return _fail(exc.args[0] if isinstance(exc, KeyError) and exc.args else exc)
    report = verdicts[0].to_dict() if len(verdicts) == 1 else compare(verdicts)
    if args.output:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(json.dumps(report, indent=2))
    if args.html or args.plot:
        images = [pictures(v) for v in verdicts]
        if args.html:
            args.html.parent.mkdir(parents=True, exist_ok=True)
            args.html.write_text(to_html(verdicts, images))
        if args.plot:
            args.plot.parent.mkdir(parents=True, exist_ok=True)
            for v, pics in zip(verdicts, images, strict=True):
                path = args.plot
                if len(verdicts) > 1:
                    path = path.with_name(f"{path.stem}_{v.robot}{path.suffix}")
                path.write_bytes(pics["floor_plan"])
    if args.page:
        write_page(verdicts, args.page)
    if args.json:
        print_json(report)
        return 0
    for v in verdicts:
        console.print(f"[bold]{v.robot}: {v.summary}[/bold] ({v.seconds:.2f} s)")
    table = compare(verdicts)
    print_table(
        f"{' vs '.join(robots)} in {verdicts[0].world}",
        ["part", "item", *robots],
        [
            [r["part"], r["item"] + (" *" if r["differ"] and len(robots) > 1 else ""), *r["values"]]
            for r in table["rows"]
            if r["part"] != "summary"
        ],
    )
    if len(robots) > 1:
        console.print("* the robots differ here")
    return 0
