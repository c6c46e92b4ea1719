"""Both papers from one command: `robotrial trials paper` runs the experiments (SLAM in
rooms A-C, navigation Table 1 at two speeds, planning Table 2, the g2rViewer desk task
under physics) and writes one self-contained HTML page that sets each table beside the
paper's figures. The tables are checked against records whose figures are known; the
command runs one experiment of each kind (the whole quick set is 37 runs)."""

from __future__ import annotations

import html
import json
import re

import pytest

from robotrial.cli import main
from robotrial.trials.paper import PAPER_NAV, PAPER_PLAN, paper_specs, paper_tables
from robotrial.trials.store import RunRecord, RunSpec, TrialStore

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]


def test_paper_specs_cover_both_papers():
    quick, full = paper_specs(quick=True), paper_specs()
    kinds = {s.kind for s in full}
    assert kinds == {"slam", "nav", "plan", "g2r"}
    assert len(full) == 6 + 60 + 60 + 20 and len(quick) < len(full)
    assert {(s.config["world"], s.config["speed"]) for s in full if s.kind == "nav"} == {
        (room, speed) for room in ("room_a", "room_b", "room_c") for speed in (0.3, 1.0)
    }


def _record(kind: str, config: dict, success: bool, figures: dict, seed: int = 0) -> RunRecord:
    return RunRecord(RunSpec(kind, config, seed), "paper", success, None, figures, {}, "w", 1, 1.0)


def _cells(text: str, first: str) -> list[str]:
    """The cells of the table row whose first cell is `first`."""
    row = re.search(rf"<tr><td>{re.escape(first)}</td>(.*?)</tr>", text)
    assert row, f"no row {first!r}"
    return re.findall(r"<td>(.*?)</td>", row.group(1))


def test_each_table_sets_the_measured_means_beside_the_papers():
    records = [
        _record("plan", {"planner": "rrt_star"}, True, {"planning_time": 1.0}, 0),
        _record("plan", {"planner": "rrt_star"}, True, {"planning_time": 1.5}, 1),
        _record("plan", {"planner": "rrt_star"}, False, {"planning_time": 9.0}, 2),
        _record("nav", {"world": "room_b", "speed": 0.3}, True, {"time": 30.0}, 0),
        _record("nav", {"world": "room_b", "speed": 0.3}, False, {"time": 99.0}, 1),
        _record("slam", {"world": "room_c", "method": "hector"}, True, {"room": {"error": 0.02}}),
        _record("g2r", {"obstacle": True}, True, {"ee_deviation": 0.004, "ee_final_error": 0.001}),
    ]
    text = html.unescape(paper_tables(records))
    # planning: the mean of the solved runs, the solved count, the paper's figure
    assert _cells(text, "rrt_star") == [str(PAPER_PLAN["rrt_star"]), "1.25", "2/3"]
    assert _cells(text, "rrt") == [str(PAPER_PLAN["rrt"]), "-", "0/0"]
    # navigation: one row per room and speed, the paper beside the 0.3 m/s rows only
    ok, t = PAPER_NAV["room_b"]
    assert re.search(
        rf"<td>room_b</td><td>0.3</td><td>{ok}/10, {t} s</td><td>1/2</td><td>30</td>", text
    )
    assert re.search(r"<td>room_b</td><td>1.0</td><td>-</td><td>0/0</td><td>-</td>", text)
    # SLAM: the room size error in cm; g2r: deviation and final error in cm
    assert re.search(r"<td>room_c</td><td>hector</td><td>wrong</td><td>2</td>", text)
    assert _cells(text, "with obstacle C") == ["1/1", "0.4", "0.1"]


def _one_run_per_row_kind() -> list[RunSpec]:
    """One quick run of each kind of table row: SLAM (GMapping) and navigation (1 m/s) in
    room B, each planner, the desk with and without obstacle C."""
    chosen, seen = [], set()
    for spec in paper_specs(quick=True):
        c = spec.config
        if spec.kind == "slam" and (c["world"], c["method"]) != ("room_b", "gmapping"):
            continue
        if spec.kind == "nav" and (c["world"], c["speed"]) != ("room_b", 1.0):
            continue
        key = (spec.kind, c.get("planner"), c.get("obstacle"))
        if key not in seen:
            seen.add(key)
            chosen.append(spec)
    return chosen


def test_the_command_runs_each_kind_and_writes_the_page(tmp_path, capsys, monkeypatch):
    """`trials paper --quick` with one run per kind and table row kind: the sweep, the
    database and the page with its tables, plots and the runs' own figures."""
    chosen = _one_run_per_row_kind()
    monkeypatch.setattr("robotrial.trials.paper.paper_specs", lambda quick, seed: chosen)
    db, page = tmp_path / "paper.db", tmp_path / "paper.html"
    args = ["trials", "paper", "--quick", "--workers", "2", "--db", str(db)]
    assert main([*args, "-o", str(page), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["sweep"]["finished"] == len(chosen) == 1 + 1 + len(PAPER_PLAN) + 2
    text = html.unescape(page.read_text())
    for title in ("SLAM in rooms A, B, C", "Table 1", "Table 2", "g2rViewer desk task"):
        assert title in text
    assert text.count("data:image/png;base64,") >= 4 + 2  # a plot per kind, a map, a path
    with TrialStore(db) as store:
        records = list(store.records())
    assert not [r.error for r in records if r.error]
    failed = [
        (r.spec.kind, r.spec.config, r.figures.get("message"))
        for r in records
        if r.spec.kind in ("g2r", "plan") and not r.success
    ]
    assert not failed, failed
    # the paper's move_base stack at 1 m/s does not always arrive (the paper's Table 1):
    # a run that does not says why
    assert all(r.success or r.figures.get("message") for r in records if r.spec.kind == "nav")
    g2r = [r for r in records if r.spec.kind == "g2r"]
    assert all(r.figures["ee_deviation"] < 0.02 for r in g2r)
    (slam,) = [r for r in records if r.spec.kind == "slam"]
    assert slam.figures["room"]["error"] < 0.05
    (rrt_star,) = [r for r in records if r.spec.config.get("planner") == "rrt_star"]
    assert _cells(text, "rrt_star")[1:] == [f"{rrt_star.figures['planning_time']:.3g}", "1/1"]
