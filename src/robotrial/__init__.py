"""robotrial: try a robot in simulation before it is bought or built.

The public Python API is the few names below (docs/python.md has runnable examples);
everything else is reached through its module. Importing `robotrial` is cheap: each
name loads its module (and MuJoCo, numba) on first use.
"""

from __future__ import annotations

import hashlib
import importlib.abc
import importlib.machinery
import os
import sys
from importlib import import_module
from pathlib import Path
from typing import Any

from robotrial.cache import cache_dir

__version__ = "0.1.0"

_PUBLIC = {
    "load_robot": "robotrial.model",
    "load_world": "robotrial.model",
    "Simulation": "robotrial.sim",
    "SimOptions": "robotrial.sim",
    "StreamSettings": "robotrial.sim",
    "TaskPlanner": "robotrial.planning.task",
    "TaskRequest": "robotrial.planning.task",
    "record_drive": "robotrial.trials.slam",
    "run_slam": "robotrial.trials.slam",
    "NavTrialSetup": "robotrial.trials.nav",
    "run_nav": "robotrial.trials.nav:run_once",
    "Recorder": "robotrial.ros.recorder",
    "read_recording": "robotrial.ros.playback",
    "CarrySetup": "robotrial.trials.carry",
    "run_carry": "robotrial.trials.carry",
    "catalogue_of": "robotrial.trials.carry",
    "Bus": "robotrial.ros.bus",
    "SimNode": "robotrial.ros.sim_node",
    "Robot": "robotrial.onboard.robot",
    "RobotSetup": "robotrial.onboard.robot",
    "Skills": "robotrial.onboard.skills",
}
"""Public name -> the module that defines it ("module:name" where the name differs)."""

__all__ = sorted(_PUBLIC)


def _numba_cache_dir() -> None:
    """Numba keeps compiled kernels on disk and checks them against their own module's
    source only, so a kernel compiled into another (an inlined collision check in the
    planner's loop, a grid update in the matcher) would outlive a change to it. One
    cache folder per state of the package's source (file names, sizes, times) rules
    that out; set before numba is imported. NUMBA_CACHE_DIR, when set, wins."""
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    root = Path(__file__).parent
    h = hashlib.sha1()
    for f in sorted(root.rglob("*.py")):
        st = f.stat()
        h.update(f"{f.relative_to(root)}:{st.st_size}:{st.st_mtime_ns}\n".encode())
    os.environ["NUMBA_CACHE_DIR"] = str(cache_dir("numba") / h.hexdigest()[:16])


_numba_cache_dir()


class _NumbaArraymath(importlib.abc.MetaPathFinder):
    """Numba's array module imports the whole of scipy.linalg (and through it numpy's
    f2py and testing: 150 ms, a sixth of a fresh `robotrial plan`) only to see whether
    BLAS is there. scipy is a dependency, so it is: the module is loaded with that
    answer given, and scipy comes in when a kernel compiles a BLAS call (numba's own
    check then runs, unchanged)."""

    def find_spec(
        self, name: str, path: Any, target: Any = None
    ) -> importlib.machinery.ModuleSpec | None:
        if name != "numba.np.arraymath":
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None or spec.loader is None:
            return spec
        run = spec.loader.exec_module

        def exec_module(module: Any) -> None:
            import numba.np.linalg as linalg

            check = getattr(linalg, "ensure_blas", None)
            if check is None:
                run(module)
                return
            linalg.ensure_blas = lambda: None
            try:
                run(module)
            finally:
                linalg.ensure_blas = check

        spec.loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


if "numba.np.arraymath" not in sys.modules:
    sys.meta_path.insert(0, _NumbaArraymath())


def __getattr__(name: str) -> Any:
    if name not in _PUBLIC:
        raise AttributeError(f"module 'robotrial' has no attribute {name!r}")
    module, _, attr = _PUBLIC[name].partition(":")
    value = getattr(import_module(module), attr or name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_PUBLIC])
