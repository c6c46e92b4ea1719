"""Recordings survive their writer: SIGKILL leaves an MCAP the stream reader reads and
`robotrial bag recover` makes whole; SIGTERM (like Ctrl+C) finishes the file; chunks
compress with lz4 (default) or zstd."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader

from robotrial.cli import main
from robotrial.ros.playback import summary

pytestmark = pytest.mark.slow
RUN = "from robotrial.cli import main; raise SystemExit(main())"


def _record(path: Path, *extra: str) -> subprocess.Popen:
    """A paced 60 s simulation recording to `path`, in its own process."""
    args = ["sim", "--world", "room_a", "--duration", "60", "--lidar-resolution", "2"]
    args += ["--realtime", "2", "--record", str(path), "--json", *extra]
    return subprocess.Popen(
        [sys.executable, "-c", RUN, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )


def _wait_for_bytes(path: Path, proc: subprocess.Popen, size: int) -> None:
    deadline = time.monotonic() + 90
    while not (path.exists() and path.stat().st_size > size):
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
        time.sleep(0.2)


def test_sigkill_then_recover(tmp_path, capsys):
    path = tmp_path / "killed.mcap"
    proc = _record(path)
    _wait_for_bytes(path, proc, 3_000_000)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    with open(path, "rb") as f, pytest.raises(Exception):  # noqa: B017
        make_reader(f).get_summary()
    streamed = 0
    with open(path, "rb") as f:
        try:
            for r in StreamReader(f).records:
                streamed += type(r).__name__ == "Message"
        except Exception:  # the torn end of the file
            pass
    assert streamed > 100

    out = tmp_path / "fixed.mcap"
    assert main(["bag", "recover", str(path), "-o", str(out), "--json"]) == 0
    recovered = json.loads(capsys.readouterr().out)["messages"]
    assert sum(recovered.values()) == streamed
    with open(out, "rb") as f:
        stats = make_reader(f).get_summary().statistics
    assert stats.message_count == streamed
    assert summary(out) == recovered and recovered["/scan"] > 5


def test_sigterm_finishes_the_recording(tmp_path):
    path = tmp_path / "termed.mcap"
    proc = _record(path, "--compression", "zstd")
    _wait_for_bytes(path, proc, 1_000_000)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    result = json.loads(out)
    assert result["interrupted"] is True
    with open(path, "rb") as f:
        reader = make_reader(f)
        s = reader.get_summary()
        assert {c.compression for c in s.chunk_indexes} == {"zstd"}
    assert s.statistics.message_count == sum(result["messages"].values())


def test_bag_commands_name_what_is_wrong(tmp_path, capsys):
    assert main(["bag", "info", str(tmp_path / "none.mcap")]) == 2
    assert "no such file" in capsys.readouterr().err
    torn = tmp_path / "torn.mcap"
    torn.write_bytes(b"\x89MCAP0\r\n" + b"\x01" * 100)
    assert main(["bag", "info", str(torn)]) == 2
    assert "robotrial bag recover" in " ".join(capsys.readouterr().err.split())
    assert main(["sim", "--record", str(tmp_path / "r.bag"), "--compression", "zstd"]) == 2
    assert "a .bag takes --compression lz4 or none" in " ".join(capsys.readouterr().err.split())
