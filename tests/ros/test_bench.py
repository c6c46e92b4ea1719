"""`robotrial bench rosbridge` runs end to end and writes its JSON (figures not judged here)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_bench_rosbridge_runs(tmp_path) -> None:
    out = tmp_path / "rosbridge.json"
    exe = Path(sys.executable).parent / "robotrial"
    proc = subprocess.run(
        [
            str(exe),
            "bench",
            "rosbridge",
            "--calls",
            "20",
            "--seconds",
            "0.2",
            "--clients",
            "1,3",
            "--output",
            str(out),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    result = json.loads(out.read_text())
    assert json.loads(proc.stdout) == result
    ours = result["robotrial"]
    assert set(ours["round_trip"]) == {
        "bus service, inline",
        "bus service, worker thread",
        "service offered by a client",
    }
    assert all(r["calls"] == 20 for r in ours["round_trip"].values())
    assert [f["clients"] for f in ours["fan_out"]] == [1, 3]
    assert all(f["sent"] == 20 for f in ours["fan_out"])
    assert (
        "skipped" in result["rosbridge_server_rs"] or "round_trip" in result["rosbridge_server_rs"]
    )
