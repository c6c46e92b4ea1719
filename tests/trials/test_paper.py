"""Both papers from one command: `robotrial trials paper --quick` runs every experiment
once over (SLAM in rooms A-C, navigation Table 1 at two speeds, planning Table 2, the
g2rViewer desk task under physics) and writes one self-contained HTML page that sets
each table beside the paper's figures."""

from __future__ import annotations

import json
import re

import pytest

from robotrial.cli import main
from robotrial.trials.paper import paper_specs
from robotrial.trials.store import TrialStore

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]


def test_paper_specs_cover_both_papers():
    quick, full = paper_specs(quick=True), paper_specs()
    kinds = {s.kind for s in full}
    assert kinds == {"slam", "nav", "plan", "g2r"}
    assert len(full) == 6 + 60 + 60 + 20 and len(quick) < len(full)
    assert {(s.config["world"], s.config["speed"]) for s in full if s.kind == "nav"} == {
        (room, speed) for room in ("room_a", "room_b", "room_c") for speed in (0.3, 1.0)
    }


def test_quick_paper_report(tmp_path, capsys):
    db, page = tmp_path / "paper.db", tmp_path / "paper.html"
    args = ["trials", "paper", "--quick", "--workers", "2", "--db", str(db)]
    assert main([*args, "-o", str(page), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["sweep"]["finished"] == len(paper_specs(quick=True))
    text = page.read_text()
    for title in ("SLAM in rooms A, B, C", "Table 1", "Table 2", "g2rViewer desk task"):
        assert title in text
    assert "10/10, 22.63 s" in text and "0.051" in text  # the papers' own figures
    assert text.count("data:image/png;base64,") >= 4 + 6  # a plot per kind, maps, paths
    with TrialStore(db) as store:
        records = list(store.records())
    assert not [r.error for r in records if r.error]
    nav = [r for r in records if r.spec.kind == "nav"]
    assert all(r.success for r in nav), [r.figures.get("message") for r in nav]
    g2r = [r for r in records if r.spec.kind == "g2r"]
    assert all(r.success and r.figures["ee_deviation"] < 0.02 for r in g2r)
    rooms = [r.figures["room"]["error"] for r in records if r.spec.kind == "slam"]
    assert len(rooms) == 6 and all(e < 0.05 for e in rooms)
    assert re.search(r"<td>rrt_star</td><td>5.016</td><td>1", text)
