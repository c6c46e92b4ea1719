"""`robotrial bench AREA`: run one area's benchmark (robotrial.benchmarks.AREA)."""

from __future__ import annotations

import argparse
import importlib
import pkgutil

import robotrial.benchmarks as benchmarks

HELP = "measure an area's speed against its baseline (planning, sim, rosbridge, slam, nav, ...)"


def areas() -> list[str]:
    return sorted(m.name for m in pkgutil.iter_modules(benchmarks.__path__) if not m.ispkg)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="area", metavar="AREA")
    for area in areas():
        mod = importlib.import_module(f"robotrial.benchmarks.{area}")
        p = sub.add_parser(area, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)
        p.set_defaults(_bench=mod.run)


# Packages some benchmarks compare against (the `bench` extra), not needed to run robotrial.
BASELINES = ("ompl", "toppra", "roslibpy")


def run(args: argparse.Namespace) -> int:
    if not getattr(args, "_bench", None):
        print(f"robotrial bench: name an area: {', '.join(areas())}")
        return 2
    try:
        return int(args._bench(args) or 0)
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] not in BASELINES:
            raise
        from robotrial.console import console

        console.print(
            f"[red]robotrial bench {args.area}: the baseline needs {exc.name}, which is not "
            "installed: pip install 'robotrial[bench]'"
        )
        return 2
