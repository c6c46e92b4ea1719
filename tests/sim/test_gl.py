"""Commands work on machines without the OpenGL the cameras need: every subcommand's
--help and short runs, with MUJOCO_GL unset and set to something unusable; a camera
switched on without a usable backend says in one line what to install."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from robotrial.cli import COMMANDS

RUN = "from robotrial.cli import main; raise SystemExit(main())"


def robotrial(args: list[str], gl: str | None, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    if gl is not None:
        env["MUJOCO_GL"] = gl
    return subprocess.run(
        [sys.executable, "-c", RUN, *args], env=env, capture_output=True, text=True, timeout=timeout
    )


HELP_ALL = """
import sys
from robotrial.cli import main
for command in sys.argv[1:]:
    print("=== " + command, flush=True)
    try:
        main([*command.split(), "--help"])
    except SystemExit as done:
        print("=== exit", done.code, flush=True)
"""


@pytest.mark.parametrize("gl", [None, "no-such-backend"])
def test_every_subcommand_help_works_whatever_the_gl(gl):
    """Each command's --help in one process per GL setting: it works, and shows the
    options' defaults."""
    commands = [*COMMANDS, "bench sim", "bench nav", "bench service", "trials run"]
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    if gl is not None:
        env["MUJOCO_GL"] = gl
    done = subprocess.run(
        [sys.executable, "-c", HELP_ALL, *commands],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert "Traceback" not in done.stderr, done.stderr
    pages = done.stdout.split("=== ")[1:]
    for command, (page, ended) in zip(
        commands, zip(pages[::2], pages[1::2], strict=True), strict=True
    ):
        assert page.startswith(command) and "usage: robotrial" in page, page
        assert ended.strip() == "exit 0", (command, ended)
    assert "(default: 60.0)" in pages[2 * commands.index("bench service")]


@pytest.mark.parametrize("gl", [None, "no-such-backend"])
def test_a_short_run_without_cameras_needs_no_gl(gl, tmp_path):
    args = ["sim", "--world", "room_a", "--duration", "0.2", "--lidar-resolution", "2"]
    done = robotrial([*args, "--plot", str(tmp_path / "run.png"), "--json"], gl)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    if gl is not None:
        assert "ignoring MUJOCO_GL=no-such-backend: MuJoCo does not know it" in done.stderr


def test_cameras_without_gl_say_what_to_install(tmp_path):
    args = ["sim", "--world", "room_a", "--duration", "0.1", "--cameras"]
    done = robotrial([*args, "--plot", str(tmp_path / "run.png")], "disable")
    assert done.returncode == 2
    assert "Traceback" not in done.stderr
    text = " ".join(done.stderr.split())
    assert "cameras need an offscreen OpenGL: install Debian's libosmesa6" in text
