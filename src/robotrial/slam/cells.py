"""How the compiled map kernels read and write a cell, whatever holds the map (layer 3).

A map is seen through a view, one of:

- a 2-D float32 array of log-odds (rows y, columns x): a `LogOddsGrid`;
- the tuple (index, pool, refs, free, top, k): particle k's map among tiles shared copy
  on write (`tiled.TiledMaps`): its index of `TILE` x `TILE` tiles (-1 where nothing was
  ever written) into the pool, each tile's count of particles holding it, and the stack
  of free tiles with its height (`top[0]`).

The ray walk (grid.py), Gauss-Newton and the likelihood field (matcher.py) are written
once against `logodds`, `add` and `block`; numba compiles each once per kind of view.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types
from numba.extending import overload

SHIFT = 5
TILE = 1 << SHIFT
MASK = TILE - 1


def logodds(view: object, r: int, c: int) -> float:
    """The log-odds of cell (r, c) of the view: 0 (unknown) outside the map. Compiled
    code only."""
    raise TypeError("cells.logodds runs in compiled kernels only")


def add(view: object, r: int, c: int, w: float, lo: float, hi: float) -> None:
    """Add `w` to cell (r, c), clamped to [lo, hi]; a cell outside the map is left.
    Compiled code only."""
    raise TypeError("cells.add runs in compiled kernels only")


def block(view: object, r: int, c: int) -> tuple[np.ndarray, int, int]:
    """The array that holds cell (r, c) and the tile around it, made writable, and the
    cell of that array's (0, 0): (array, r0, c0), cell (r, c) at array[r - r0, c - c0]
    when that lies inside the array (else the cell is outside the map). A walk over the
    cells writes through it while it stays in the tile (r >> SHIFT, c >> SHIFT), so a
    tile is made a particle's own once a walk, not once a cell. Compiled code only."""
    raise TypeError("cells.block runs in compiled kernels only")


@numba.njit(cache=True, nogil=True, inline="always")
def own_tile(
    index: np.ndarray, pool: np.ndarray, refs: np.ndarray, free: np.ndarray,
    top: np.ndarray, k: int, tr: int, tc: int,
) -> int:  # fmt: skip
    """The tile (tr, tc) of particle k, made its own: a shared one copied, a missing one
    taken from the free stack (the caller reserved enough)."""
    t = index[k, tr, tc]
    if t >= 0 and refs[t] == 1:
        return t
    top[0] -= 1
    nt = free[top[0]]
    if t < 0:
        pool[nt, :, :] = 0.0
    else:
        pool[nt, :, :] = pool[t, :, :]
        refs[t] -= 1
    refs[nt] = 1
    index[k, tr, tc] = nt
    return nt


def _is_tiles(view: types.Type) -> bool:
    return isinstance(view, types.BaseTuple) and len(view) == 6


@overload(logodds, jit_options={"nogil": True})
def _logodds(view, r, c):  # type: ignore[no-untyped-def]
    if isinstance(view, types.Array) and view.ndim == 2:

        def dense(view, r, c):  # type: ignore[no-untyped-def]
            rows, cols = view.shape
            if r < 0 or c < 0 or r >= rows or c >= cols:
                return 0.0
            return float(view[r, c])

        return dense
    if _is_tiles(view):

        def tiles(view, r, c):  # type: ignore[no-untyped-def]
            index, pool, k = view[0], view[1], view[5]
            if r < 0 or c < 0:
                return 0.0
            tr, tc = r >> SHIFT, c >> SHIFT
            if tr >= index.shape[1] or tc >= index.shape[2]:
                return 0.0
            t = index[k, tr, tc]
            if t < 0:
                return 0.0
            return float(pool[t, r & MASK, c & MASK])

        return tiles
    return None


@overload(add, jit_options={"nogil": True})
def _add(view, r, c, w, lo, hi):  # type: ignore[no-untyped-def]
    if isinstance(view, types.Array) and view.ndim == 2:

        def dense(view, r, c, w, lo, hi):  # type: ignore[no-untyped-def]
            rows, cols = view.shape
            if 0 <= r < rows and 0 <= c < cols:
                v = view[r, c] + w
                view[r, c] = hi if v > hi else (lo if v < lo else v)

        return dense
    if _is_tiles(view):

        def tiles(view, r, c, w, lo, hi):  # type: ignore[no-untyped-def]
            index, pool = view[0], view[1]
            if r < 0 or c < 0 or (r >> SHIFT) >= index.shape[1] or (c >> SHIFT) >= index.shape[2]:
                return
            t = own_tile(index, pool, view[2], view[3], view[4], view[5], r >> SHIFT, c >> SHIFT)
            v = pool[t, r & MASK, c & MASK] + w
            pool[t, r & MASK, c & MASK] = hi if v > hi else (lo if v < lo else v)

        return tiles
    return None


@overload(block, jit_options={"nogil": True})
def _block(view, r, c):  # type: ignore[no-untyped-def]
    if isinstance(view, types.Array) and view.ndim == 2:

        def dense(view, r, c):  # type: ignore[no-untyped-def]
            return view, 0, 0

        return dense
    if _is_tiles(view):

        def tiles(view, r, c):  # type: ignore[no-untyped-def]
            index, pool = view[0], view[1]
            tr, tc = r >> SHIFT, c >> SHIFT
            if r < 0 or c < 0 or tr >= index.shape[1] or tc >= index.shape[2]:
                return pool[0][:0], 0, 0
            t = own_tile(index, pool, view[2], view[3], view[4], view[5], tr, tc)
            return pool[t], tr << SHIFT, tc << SHIFT

        return tiles
    return None
