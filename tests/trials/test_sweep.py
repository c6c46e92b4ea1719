"""Trial sweeps: every run stored once, through dead workers, Ctrl+C and --resume, on a
local process pool and on a local Ray instance; the CLI and its HTML report."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
from collections import Counter
from multiprocessing import active_children
from pathlib import Path

import pytest

from robotrial.cli import main
from robotrial.trials.store import TrialStore
from robotrial.trials.sweep import AlreadyRun, LocalExecutor, RayExecutor, grid, run_sweep

# RRT* plans for its whole time limit: each run lasts a known second, long enough for a
# worker to be killed while it holds one.
SETTINGS = {"planner": ["rrt_star"], "time_limit": [1.0]}


def _stored_keys(db: Path) -> Counter:
    with sqlite3.connect(db) as con:
        return Counter(k for (k,) in con.execute("SELECT key FROM runs"))


def test_grid_sweeps_every_combination_and_names_unknown_settings():
    specs = grid("plan", {"planner": ["rrt", "rrt_connect"], "scene": ["desk"]}, range(3))
    assert len(specs) == 6 and len({s.key for s in specs}) == 6
    assert {s.config["planner"] for s in specs} == {"rrt", "rrt_connect"}
    with pytest.raises(ValueError, match="no setting wrld; its settings: world"):
        grid("nav", {"wrld": ["room_a"]}, [0])
    with pytest.raises(ValueError, match="unknown trial kind 'dance'"):
        grid("dance", {}, [0])


def test_store_refuses_a_file_that_is_not_a_database(tmp_path):
    bad = tmp_path / "notes.db"
    bad.write_text("these are my notes, not a database\n" * 50)
    with pytest.raises(ValueError, match=r"notes\.db: not an SQLite file"):
        TrialStore(bad)
    assert bad.read_text().startswith("these are my notes")


def _kill_one_worker_once(kill):
    """An on_record hook that kills one worker after the first stored run."""
    state = {"killed": False}

    def on_record(rec) -> None:
        if not state["killed"]:
            state["killed"] = kill()

    return on_record, state


def test_local_pool_survives_a_killed_worker(tmp_path):
    specs = grid("plan", SETTINGS, range(6))

    def kill() -> bool:
        workers = [p for p in active_children() if p.is_alive()]
        if not workers:
            return False
        os.kill(workers[0].pid, signal.SIGKILL)
        return True

    on_record, state = _kill_one_worker_once(kill)
    with TrialStore(tmp_path / "t.db") as store:
        res = run_sweep(specs, store, LocalExecutor(2), "s", tmp_path, on_record=on_record)
        records = list(store.records())
    assert state["killed"] and res.lost >= 1
    assert res.finished == 6 and not res.interrupted
    assert _stored_keys(tmp_path / "t.db") == Counter(s.key for s in specs)
    assert all(r.error is None and r.success for r in records)
    assert any(r.attempts > 1 for r in records)


def _ray_workers() -> list[int]:
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                cmd = (d / "cmdline").read_bytes()
            except OSError:
                continue
            if cmd.startswith(b"ray::execute"):
                pids.append(int(d.name))
    return pids


@pytest.mark.slow
def test_local_ray_survives_a_killed_worker(tmp_path):
    specs = grid("plan", SETTINGS, range(6))

    def kill() -> bool:
        busy = _ray_workers()
        if not busy:
            return False
        os.kill(busy[0], signal.SIGKILL)
        return True

    on_record, state = _kill_one_worker_once(kill)
    executor = RayExecutor("local", 2)
    with TrialStore(tmp_path / "t.db") as store:
        res = run_sweep(specs, store, executor, "s", tmp_path, on_record=on_record)
        records = list(store.records())
    assert state["killed"] and res.lost >= 1
    assert res.finished == 6
    assert _stored_keys(tmp_path / "t.db") == Counter(s.key for s in specs)
    assert all(r.error is None for r in records)
    assert any(r.attempts > 1 for r in records)


def test_interrupted_sweep_resumes_without_repeating_a_run(tmp_path):
    specs = grid("plan", {"planner": ["rrt_connect"]}, range(5))
    stored = []

    def interrupt_after_two(rec) -> None:
        stored.append(rec.spec.key)
        if len(stored) == 2:
            raise KeyboardInterrupt

    db = tmp_path / "t.db"
    with TrialStore(db) as store:
        res = run_sweep(
            specs, store, LocalExecutor(1), "s", tmp_path, on_record=interrupt_after_two
        )
    assert res.interrupted and res.finished == 2
    with TrialStore(db) as store:
        with pytest.raises(AlreadyRun, match="already holds 2 of these 5 runs; add --resume"):
            run_sweep(specs, store, LocalExecutor(1), "s", tmp_path)
        res = run_sweep(specs, store, LocalExecutor(1), "s", tmp_path, resume=True)
    assert (res.skipped, res.finished) == (2, 3)
    assert _stored_keys(db) == Counter(s.key for s in specs)


def test_a_run_that_raises_is_stored_with_its_error(tmp_path):
    specs = grid("plan", {"scene": ["attic"]}, range(2))
    with TrialStore(tmp_path / "t.db") as store:
        res = run_sweep(specs, store, LocalExecutor(1), "s", tmp_path)
        records = list(store.records())
    assert res.finished == 2 and res.lost == 0
    assert all(r.success is False for r in records)
    assert all("unknown planning scene 'attic'" in r.error for r in records)
    assert all("kinds.py:" in r.error for r in records)


def test_cli_sweep_then_report(tmp_path, capsys):
    db = tmp_path / "plan.db"
    args = ["trials", "run", "plan", "--set", "planner=rrt", "--set", "planner=rrt_connect"]
    args += ["--runs", "2", "--workers", "2", "--db", str(db), "--json"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["sweep"]["finished"] == 4
    groups = {g["configuration"]: g for g in out["groups"]}
    assert set(groups) == {"planner=rrt", "defaults"}
    assert all(g["runs"] == 2 and g["successes"] == 2 for g in groups.values())
    assert all(0 < g["mean"] < 5.0 for g in groups.values())

    assert main(args) == 2
    assert "add --resume" in capsys.readouterr().err
    assert main([*args, "--resume"]) == 0
    assert json.loads(capsys.readouterr().out)["sweep"]["skipped"] == 4

    page = tmp_path / "plan.html"
    assert main(["trials", "report", str(db), "-o", str(page)]) == 0
    text = page.read_text()
    assert "<h2>plan</h2>" in text and "planner=rrt" in text
    assert text.count("data:image/png;base64,") == 1
    assert main(["trials", "report", str(tmp_path / "missing.db")]) == 2
    assert "no database at" in capsys.readouterr().err
    assert main(["trials", "run", "plan", "--set", "planner", "--db", str(db)]) == 2
    assert "expected KEY=VALUE" in capsys.readouterr().err
