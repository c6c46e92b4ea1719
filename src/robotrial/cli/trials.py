"""`robotrial trials`: sweeps of trials over seeds and settings, and their report (layer 5).

    robotrial trials run nav --set world=room_a --set world=room_b --runs 10 --workers 2
    robotrial trials run plan --set planner=rrt --set planner=rrt_star --ray local
    robotrial trials run nav --runs 10 --resume          # after Ctrl+C or a lost node
    robotrial trials report trials.db -o trials.html
    robotrial trials paper --quick --workers 2      # both papers, one HTML report
    robotrial trials carry --object cup --to bedroom  # map, drive, pick, carry, place
    robotrial trials run carry --set to=kitchen --set to=bedroom --runs 10 --workers 2

A setting given more than once is swept; every combination runs with seeds
seed..seed+runs-1. Each run is a row of the SQLite database as soon as it ends.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from robotrial.console import add_json_flag, console, print_json, print_table, progress

HELP = "sweeps of trials on local processes or Ray, stored in SQLite; reports; both papers"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    run = sub.add_parser("run", help="run a sweep (skipping runs the database holds)")
    run.add_argument("kind", help="trial kind: nav, plan, slam, g2r or carry")
    run.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a setting (YAML value, e.g. world=room_b or goal=[6.8,6.6,0]); "
        "give a key more than once to sweep it",
    )
    run.add_argument("--runs", type=int, default=1, help="seeds per configuration")
    run.add_argument("--name", help="the sweep's name in the database (default: the kind)")
    _sweep_options(run, "trials.db")
    paper = sub.add_parser("paper", help="both papers' experiments and one HTML report")
    paper.add_argument("--quick", action="store_true", help="fewer seeds, shorter drives")
    paper.add_argument("-o", "--output", default="paper.html", help="the HTML report")
    _sweep_options(paper, "paper.db")
    carry = sub.add_parser(
        "carry", help="one robot maps the home, picks an object, carries it to a room"
    )
    carry.add_argument("--world", default="apartment", help="a world with rooms and a route")
    carry.add_argument("--object", default="cup", help="the object to carry")
    carry.add_argument("--to", default="bedroom", help="the room to set it down in")
    carry.add_argument("--slam", default="graph", choices=["graph", "hector", "gmapping"])
    carry.add_argument("--speed", type=float, default=0.5, help="top speed (m/s)")
    carry.add_argument("--seed", type=int, default=0)
    carry.add_argument(
        "--mapping",
        choices=["auto", "route", "frontier"],
        default="auto",
        help="map along the given route, or explore by frontiers on its own; auto: the "
        "route where the world has one (the apartment), else frontiers",
    )
    carry.add_argument("-o", "--output", default="carry", help="folder for the MCAP, JSON and plot")
    add_json_flag(carry)
    rep = sub.add_parser("report", help="turn a trial database into an HTML page")
    rep.add_argument("db", help="SQLite file written by `robotrial trials run`")
    rep.add_argument("-o", "--output", help="HTML file (default: the db's name with .html)")


def _sweep_options(parser: argparse.ArgumentParser, db: str) -> None:
    parser.add_argument("--seed", type=int, default=0, help="the first seed")
    parser.add_argument(
        "--workers",
        type=int,
        help="runs at once: local processes (default 1) or Ray tasks (default: its CPUs)",
    )
    parser.add_argument(
        "--ray", metavar="ADDRESS", help="run on a Ray cluster (e.g. auto, or local to start one)"
    )
    parser.add_argument("--db", default=db, help=f"SQLite file of the runs (default {db})")
    parser.add_argument(
        "--files", metavar="DIR", help="folder for files runs write (default: beside the db)"
    )
    parser.add_argument("--resume", action="store_true", help="run what the database lacks")
    add_json_flag(parser)


def settings(items: list[str]) -> dict[str, list]:
    """KEY=VALUE items as {key: [values in order given]}; values are YAML."""
    import yaml

    out: dict[str, list] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set {item!r}: expected KEY=VALUE")
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ValueError(f"--set {item!r}: the value is not valid YAML ({exc})") from exc
        out.setdefault(key.strip(), []).append(value)
    return out


def run(args: argparse.Namespace) -> int:
    if args.action == "report":
        return _report(args)
    if args.action == "carry":
        return _carry(args)
    from robotrial.trials.sweep import grid

    try:
        if args.action == "paper":
            from robotrial.trials.paper import paper_specs

            specs, name = paper_specs(args.quick, args.seed), "paper"
        else:
            if args.runs < 1:
                raise ValueError(f"--runs must be at least 1, got {args.runs}")
            seeds = range(args.seed, args.seed + args.runs)
            specs, name = grid(args.kind, settings(args.set), seeds), args.name or args.kind
    except ValueError as exc:
        console.print(f"[red]robotrial trials: {exc}[/red]")
        return 2
    done = _sweep(args, specs, name)
    if done is None:
        return 2
    result, summary = done
    if args.action == "paper":
        return _paper_page(args, result)
    if args.json:
        print_json({"db": args.db, "sweep": vars(result), "groups": summary})
    else:
        print_table(
            f"robotrial trials {args.kind}: {result.finished} run now, {result.skipped} "
            f"already in {args.db}, {result.lost} lost to dead workers",
            ["configuration", "runs", "successes", "errors", "figure", "mean", "min", "max"],
            [
                [g[c] for c in ("configuration", "runs", "successes", "errors", "figure")]
                + [g["mean"], g["min"], g["max"]]
                for g in summary
            ],
        )
    return 130 if result.interrupted else 0


def _sweep(args: argparse.Namespace, specs: list, name: str):
    """Run the sweep with a progress bar; (result, group summaries), or None after
    printing why it could not start."""
    from robotrial.trials.store import TrialStore
    from robotrial.trials.sweep import AlreadyRun, LocalExecutor, RayExecutor, run_sweep

    out = Path(args.files) if args.files else Path(args.db).with_suffix("")
    failed: list[str] = []
    try:
        store = TrialStore(args.db)
    except ValueError as exc:
        console.print(f"[red]robotrial trials: {exc}[/red]")
        return None
    with store:
        try:
            executor = RayExecutor(args.ray, args.workers) if args.ray else None
            executor = executor or LocalExecutor(args.workers or 1)
        except ValueError as exc:
            console.print(f"[red]robotrial trials: {exc}[/red]")
            return None
        with progress(f"trials {name}", len(specs), enabled=not args.json) as advance:

            def on_record(rec) -> None:
                advance()
                if rec.error:
                    failed.append(f"{rec.spec.kind} seed {rec.spec.seed}: {rec.error}")

            try:
                result = run_sweep(
                    specs, store, executor, name, out, resume=args.resume, on_record=on_record
                )
            except AlreadyRun as exc:
                executor.close()
                console.print(f"[red]robotrial trials: {exc}[/red]")
                return None
            if result.skipped:
                advance(result.skipped)
        summary = _summaries(store, specs)
    for line in failed:
        console.print(f"[yellow]{line}[/yellow]")
    if result.interrupted:
        console.print(
            f"[yellow]interrupted: {result.skipped + result.finished} of {result.total} runs "
            f"are in {args.db}; run the same command with --resume for the rest[/yellow]"
        )
    return result, summary


def _paper_page(args: argparse.Namespace, result) -> int:
    from robotrial.trials.paper import paper_report
    from robotrial.trials.store import TrialStore

    page = Path(args.output)
    with TrialStore(args.db) as store:
        page.write_text(paper_report(store))
    if args.json:
        print_json({"db": args.db, "sweep": vars(result), "report": str(page)})
    else:
        console.print(f"wrote {page} ({result.finished} runs now, {result.skipped} kept)")
    return 130 if result.interrupted else 0


def _summaries(store, specs) -> list[dict]:
    from robotrial.trials.report import config_label, group_runs, group_summary

    keys = {s.key for s in specs}
    records = [r for r in store.records() if r.spec.key in keys]
    return [
        {"configuration": config_label(runs[0].spec.config, kind), **group_summary(kind, runs)}
        for (kind, _), runs in group_runs(records).items()
    ]


def _report(args: argparse.Namespace) -> int:
    from robotrial.trials.report import html_report
    from robotrial.trials.store import TrialStore

    if not Path(args.db).is_file():
        console.print(f"[red]robotrial trials report: no database at {args.db}[/red]")
        return 2
    try:
        with TrialStore(args.db) as store:
            page = html_report(store, f"robotrial trials: {Path(args.db).name}")
    except ValueError as exc:
        console.print(f"[red]robotrial trials report: {exc}[/red]")
        return 2
    out = Path(args.output) if args.output else Path(args.db).with_suffix(".html")
    out.write_text(page)
    console.print(f"wrote {out}")
    return 0


def _carry(args: argparse.Namespace) -> int:
    from robotrial.trials.carry import CarrySetup, run_carry

    try:
        setup = CarrySetup(
            world=args.world,
            object=args.object,
            to=args.to,
            slam=args.slam,
            speed=args.speed,
            mapping=args.mapping,
        )
        out = Path(args.output)
        with progress(
            f"carry {args.object} to the {args.to}", setup.time_limit, enabled=not args.json
        ) as advance:
            seen = [0.0]

            def on_progress(phase: str, t: float) -> None:
                advance(t - seen[0])
                seen[0] = t

            result = run_carry(setup, args.seed, out, on_progress)
    except (KeyError, ValueError) as exc:
        console.print(f"[red]robotrial trials carry: {str(exc).strip(chr(34))}[/red]")
        return 2
    summary = result.summary()
    if args.json:
        print_json(summary)
    else:
        print_table(
            f"carry {args.object} to the {args.to}, seed {args.seed}: "
            + (
                "success" if result.success else f"failed in {result.failed_phase} ({result.cause})"
            ),
            ["phase", "start (s)", "time (s)", "wall (s)"],
            [[p["phase"], p["start"], p["time"], p["wall_time"]] for p in summary["phases"]],
        )
        if not result.success:
            console.print(f"[red]{result.failed_phase} ({result.cause}): {result.reason}[/red]")
        else:
            console.print(
                f"placed {100 * (result.place_error or 0):.1f} cm from the place point, "
                f"tilted {summary['tilt_deg']} deg; {result.sim_time:.0f} s simulated in "
                f"{result.wall_time:.0f} s ({summary['real_time_factor']}x real time)"
            )
        console.print(f"grasp: {result.grasp or 'none'}")
        console.print(f"oracles used: {', '.join(result.oracles) or 'none'}")
        console.print(f"wrote {out}/carry_{args.seed}.mcap, .json and .png")
    return 0 if result.success else 1
