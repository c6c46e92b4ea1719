"""Printing for people (rich tables) and programs (`--json`), and progress bars: used by
the command line and the benchmarks alike (it imports nothing from the project)."""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table

console = Console(stderr=True, soft_wrap=True)
"""Messages and progress on stderr; a message stays one line (a terminal wraps it, not
rich), so that scripts and logs read an error as the one line it is."""


def _plain(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def print_json(data: Any) -> None:
    """Machine-readable result on stdout."""
    sys.stdout.write(json.dumps(_plain(data), indent=2) + "\n")


def write_result(result: Mapping[str, Any], path: str | Path | None) -> None:
    """Write a result as JSON to `path`, its folder made if missing (nothing when no path
    was given): what `-o/--output` asks of every benchmark."""
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps(_plain(result), indent=2))


def emit(result: dict[str, Any], args: argparse.Namespace, *, load_after: bool = False) -> bool:
    """Write a benchmark's result to `--output` and print it when `--json` asks; True when
    printed, so the caller ends there instead of printing its table. `load_after` adds the
    load average at the end of the run, beside the one taken at its start."""
    if load_after:
        result["load_average_after"] = list(os.getloadavg())
    write_result(result, args.output)
    if args.json:
        print_json(result)
    return bool(args.json)


def print_table(title: str, columns: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
    table = Table(title=title)
    for c in columns:
        table.add_column(str(c))
    for r in rows:
        table.add_row(*(_cell(v) for v in r))
    Console().print(table)


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def add_json_flag(parser) -> None:
    parser.add_argument("--json", action="store_true", help="print the result as JSON")


@contextmanager
def progress(description: str, total: float | None, enabled: bool = True):
    """A progress bar on stderr; yields `advance(n=1)`. Hidden when stderr is not a TTY
    and `enabled` is False, so `--json` output stays clean."""
    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        disable=not enabled,
        transient=False,
    ) as bar:
        task = bar.add_task(description, total=total)

        def advance(n: float = 1.0) -> None:
            bar.advance(task, n)

        yield advance
