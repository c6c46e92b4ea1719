"""`robotrial bag`: look into a recording, rescue one cut short (layer 5).

    robotrial bag info run.mcap              # topics, types, messages (from the index)
    robotrial bag info rosbag2_2026_01_01/   # a ROS 2 bag folder (sqlite3 or MCAP), or a .db3
    robotrial bag recover run.mcap -o fixed.mcap

`recover` copies every message of the complete chunks of an MCAP or ROS 1 .bag whose
writer was killed or ran out of disk (no index, a torn last chunk) into an indexed file
that Foxglove, rosbag and seeking readers open.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from robotrial.console import add_json_flag, console, print_json, print_table

HELP = "recordings: messages per topic (info), rescue a recording cut short (recover)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    info = sub.add_parser(
        "info", help="topics, types and messages of a .mcap, .bag, .db3 or ROS 2 bag folder"
    )
    info.add_argument("file")
    add_json_flag(info)
    rec = sub.add_parser(
        "recover", help="rewrite a recording cut short (.mcap or .bag) as a complete file"
    )
    rec.add_argument("file")
    rec.add_argument("-o", "--output", help="where to write (default: FILE.recovered.mcap/.bag)")
    add_json_flag(rec)


def run(args: argparse.Namespace) -> int:
    from robotrial.ros.playback import contents
    from robotrial.ros.recorder import recover_bag, recover_mcap

    path = Path(args.file)
    if not path.exists():
        console.print(f"[red]robotrial bag: no such file {path}[/red]")
        return 2
    types: dict[str, str] = {}
    try:
        if args.action == "info":
            found = contents(path)
            counts = {t: n for t, (_, n) in found.items()}
            types = {t: ty for t, (ty, _) in found.items()}
            title = f"{path.name}: {sum(counts.values())} messages"
        else:
            suffix = path.suffix.lower()
            if suffix not in (".mcap", ".bag"):
                raise ValueError(f"{path}: only .mcap and ROS 1 .bag files can be recovered")
            out = Path(args.output) if args.output else path.with_suffix(".recovered" + suffix)
            counts = (recover_mcap if suffix == ".mcap" else recover_bag)(path, out)
            title = f"{out}: {sum(counts.values())} messages recovered from {path.name}"
    except (ValueError, OSError) as exc:
        console.print(f"[red]robotrial bag: {exc}[/red]")
        return 2
    except Exception as exc:  # a reader that meets a torn file raises its own kinds
        console.print(
            f"[red]robotrial bag: {path} cannot be read ({exc}); "
            "if it was cut short, try: robotrial bag recover FILE[/red]"
        )
        return 2
    if args.json:
        out = {"file": str(path), "messages": counts, "title": title}
        if types:
            out["types"] = types
        print_json(out)
    elif types:
        rows = [(t, types[t], n) for t, n in sorted(counts.items())]
        print_table(title, ["topic", "type", "messages"], rows)
    else:
        print_table(title, ["topic", "messages"], sorted(counts.items()))
    return 0
