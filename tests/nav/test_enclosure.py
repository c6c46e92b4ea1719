"""way_out: a walled room is closed; a gap in its wall gives the shortest way out, through
the gap; walls that touch only at a corner still close it; a start in a wall has none."""

from __future__ import annotations

import numpy as np

from robotrial.nav.enclosure import way_out


def room(gap_rows: slice | None = None) -> np.ndarray:
    """A 20 x 30 grid with a wall ring at rows 2 and 17, columns 2 and 27; `gap_rows`
    opens that part of the east wall."""
    occupied = np.zeros((20, 30), dtype=bool)
    occupied[2, 2:28] = occupied[17, 2:28] = True
    occupied[2:18, 2] = occupied[2:18, 27] = True
    if gap_rows is not None:
        occupied[gap_rows, 27] = False
    return occupied


def test_a_closed_room_has_no_way_out() -> None:
    assert way_out(room(), (10, 10)) is None


def test_a_gap_gives_the_shortest_way_out_through_it() -> None:
    occupied = room(slice(12, 14))
    path = way_out(occupied, (10, 10))
    assert path is not None
    assert tuple(path[0]) == (10, 10) and path[-1][1] == 29  # out on the east edge
    through = [tuple(p) for p in path if p[1] == 27]
    assert through and all(12 <= r < 14 for r, _ in through)
    steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
    assert np.all(steps == 1) and not occupied[path[:, 0], path[:, 1]].any()
    assert len(path) == 1 + 2 + 19  # two rows down to the gap, 19 columns east


def test_walls_meeting_only_at_a_corner_still_close_the_room() -> None:
    occupied = room()
    occupied[17, 27] = False  # the south-east corner open: inside, (16, 26) meets it
    occupied[17, 26] = occupied[16, 27] = True  # only diagonally, between two wall cells
    assert way_out(occupied, (10, 10)) is None


def test_a_start_in_a_wall_or_off_the_grid_has_none() -> None:
    open_room = room(slice(12, 14))
    assert way_out(open_room, (2, 10)) is None
    assert way_out(open_room, (40, 10)) is None
