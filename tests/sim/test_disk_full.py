"""A disk that fills up while `robotrial sim --record` runs (a real one: a 2 MiB tmpfs):
one line names the file and the error, the run stops, and what was written is either
readable as it is or rescued by `robotrial bag recover`, which the line names."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from robotrial.cli import main
from robotrial.ros.playback import summary


@pytest.fixture
def small_disk(tmp_path) -> Iterator[Path]:
    """A 2 MiB filesystem of its own (tmpfs; mounting needs root, as CI and the project's
    machines run)."""
    mount = tmp_path / "disk"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount)],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        pytest.fail(f"a 2 MiB tmpfs is needed (run as root): {done.stderr.strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=True)


@pytest.mark.parametrize("name", ["run.bag", "run.mcap"])
def test_full_disk_stops_the_run_and_keeps_what_was_written(small_disk, tmp_path, name, capsys):
    path = small_disk / name
    args = ["sim", "--world", "room_a", "--duration", "60", "--lidar-resolution", "0.4"]
    args += ["--compression", "none"]
    assert main([*args, "--record", str(path), "--json"]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    line = lines[0]
    assert f"cannot write {path}: No space left on device" in line
    stopped = float(line.split("the run stopped at ")[1].split(" s")[0])
    assert 0 < stopped < 60
    if "bag recover" in line:
        fixed = tmp_path / f"fixed{path.suffix}"
        assert main(["bag", "recover", str(path), "-o", str(fixed), "--json"]) == 0
        recovered = json.loads(capsys.readouterr().out)["messages"]
        assert summary(fixed) == recovered
    else:
        assert "readable" in line
        recovered = summary(path)
    assert recovered["/scan"] >= 2 and recovered["/tf_static"] == 1
