"""Where robotrial keeps what it computes or downloads once (layer 0, standard library
only): $ROBOTRIAL_CACHE, else $XDG_CACHE_HOME/robotrial, else ~/.cache/robotrial, one
sub-folder per kind of thing (numba's kernels, robot collision models, logs, data sets)."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir(kind: str = "") -> Path:
    """The cache folder, or its sub-folder `kind` (not created here)."""
    base = os.environ.get("ROBOTRIAL_CACHE") or Path(
        os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache", "robotrial"
    )
    return Path(base, kind) if kind else Path(base)
