"""The robot maps a small generated home on its own: frontiers, SLAM, the default
navigator, nothing told about the home."""

from __future__ import annotations

from robotrial.trials.explore import ExploreSetup, run_explore


def test_a_two_room_home_is_mapped_without_contact_and_exploring_stops_by_itself() -> None:
    r = run_explore(ExploreSetup(world="home:1:2", time_limit=120.0), seed=0)
    assert r.finished, r.stopped
    assert r.stopped == "no reachable frontier left"
    assert r.coverage >= 0.95, f"{100 * r.coverage:.1f} % of the reachable free area mapped"
    assert r.contacts == 0, r.touched
    assert r.path_length > 2.0  # it drove through the doorway
