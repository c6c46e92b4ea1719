"""The `robotrial` command: parses arguments, calls one subcommand module, prints.

Layer 5. Each subcommand is a module in this package with `HELP` (one line),
`add_arguments(parser)` and `run(args) -> int`; only the chosen one is imported, so the
command starts fast.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import sys
import threading

from robotrial.gl import choose_gl_backend

# name -> module in robotrial.cli, in the order `robotrial --help` lists them
COMMANDS: dict[str, str] = {
    "serve": "serve",
    "convert": "convert",
    "info": "info",
    "sim": "sim",
    "plan": "plan",
    "warm": "warm",
    "rosbridge": "rosbridge",
    "slam": "slam",
    "nav": "nav",
    "explore": "explore",
    "verdict": "verdict",
    "bag": "bag",
    "trials": "trials",
    "bench": "bench",
}
NO_CAMERAS = {"plan", "warm"}
"""Commands that use MuJoCo for collisions only: its OpenGL is not loaded for them (a
third of a second of `robotrial plan`), unless MUJOCO_GL asks for one."""
QUICK_EXIT = {"plan"}
"""Commands whose process ends as soon as their output is out, without the interpreter's
teardown: freeing numba's compiler state alone takes a quarter of a second, a fifth of a
fresh `robotrial plan`. Only when run as the command (`main()` without arguments)."""


def _available() -> dict[str, object]:
    mods = {}
    for name, mod in COMMANDS.items():
        try:
            mods[name] = importlib.import_module(f"robotrial.cli.{mod}")
        except ModuleNotFoundError as exc:
            if exc.name != f"robotrial.cli.{mod}":
                raise
    return mods


class _DefaultsShown(argparse.HelpFormatter):
    """Help that ends each option's text with its default, unless the text names it."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        quiet = (None, False, argparse.SUPPRESS, [])
        if not action.option_strings or "default" in text or action.default in quiet:
            return text
        return f"{text} (default: %(default)s)"


class _Parser(argparse.ArgumentParser):
    """The command's parser; its subcommands' parsers are of this class too (argparse
    makes them of the parent's class), so every --help shows the defaults."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", _DefaultsShown)
        super().__init__(*args, **kwargs)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("robotrial")
    except PackageNotFoundError:
        return "unknown (not installed)"


def build_parser(selected: str | None = None) -> argparse.ArgumentParser:
    parser = _Parser(
        prog="robotrial",
        description="Try a robot in simulation: web app, rosbridge, physics, SLAM, "
        "navigation and arm planning.",
    )
    parser.add_argument("--version", action="version", version=f"robotrial {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    if selected in COMMANDS:
        mods = {selected: importlib.import_module(f"robotrial.cli.{COMMANDS[selected]}")}
    else:
        mods = _available()
    for name, mod in mods.items():
        p = sub.add_parser(name, help=mod.HELP, description=mod.HELP)  # type: ignore[attr-defined]
        mod.add_arguments(p)  # type: ignore[attr-defined]
        p.set_defaults(_run=mod.run)  # type: ignore[attr-defined]
    return parser


def _stop(signum: int, _frame: object) -> None:
    """SIGTERM ends a command as Ctrl+C does: recordings are finished, files closed."""
    raise KeyboardInterrupt(f"signal {signum}")


def main(argv: list[str] | None = None) -> int:
    """Run the command in `argv` (default: this process's arguments); its exit code."""
    if argv is not None:
        return _main(argv)
    code = _main(sys.argv[1:])
    if sys.argv[1:2] and sys.argv[1] in QUICK_EXIT:
        logging.shutdown()
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except OSError:  # the reader has gone (`robotrial plan ... | head`)
            pass
        os._exit(code)
    return code


def _main(argv: list[str]) -> int:
    first = next((a for a in argv if not a.startswith("-")), None)
    if first in NO_CAMERAS and "mujoco" not in sys.modules:
        os.environ.setdefault("MUJOCO_GL", "disable")
    choose_gl_backend()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _stop)
    parser = build_parser(first)
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        return int(args._run(args) or 0)
    except KeyboardInterrupt as stop:  # Ctrl+C or SIGTERM: the command has cleaned up
        return 128 + (signal.SIGTERM if str(stop).startswith("signal") else signal.SIGINT)


if __name__ == "__main__":
    sys.exit(main())
