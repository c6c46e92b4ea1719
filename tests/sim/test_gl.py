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


@pytest.mark.parametrize("gl", [None, "no-such-backend"])
def test_every_subcommand_help_works_whatever_the_gl(gl):
    for command in [*COMMANDS, "bench sim", "bench nav", "trials run"]:
        done = robotrial([*command.split(), "--help"], gl)
        assert done.returncode == 0, (command, done.stderr)
        assert "Traceback" not in done.stderr, (command, done.stderr)
        assert "usage: robotrial" in done.stdout


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
