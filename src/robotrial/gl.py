"""Which OpenGL the simulated cameras render with, chosen before MuJoCo is imported.

MuJoCo reads `MUJOCO_GL` once, when it is imported, and a backend whose library is
missing (`osmesa` without Debian's libosmesa6) makes `import mujoco` itself fail, even
for runs with no camera. So the command line chooses first: a user's usable choice is
kept; otherwise OSMesa if its library loads, else EGL, else nothing (MuJoCo imports, and
only a camera, when switched on, says what to install). An unusable choice is dropped
with one line on stderr.
"""

from __future__ import annotations

import ctypes.util
import os
import sys

# MUJOCO_GL values and the library each needs (None: nothing to check at import).
_NEEDS = {"osmesa": "OSMesa", "egl": "EGL"}
_HARMLESS = {"", "glfw", "glx", "enable", "enabled", "on", "true", "1"}
_OFF = {"disable", "disabled", "off", "false", "0"}
INSTALL_HINT = (
    "cameras need an offscreen OpenGL: install Debian's libosmesa6 "
    "(sudo apt-get install libosmesa6) or libegl1, or run without cameras"
)


def _loads(lib: str) -> bool:
    return ctypes.util.find_library(lib) is not None


def choose_gl_backend() -> str | None:
    """Set MUJOCO_GL (and PYOPENGL_PLATFORM) for offscreen rendering if it is not set
    to something usable; the backend chosen, or None when there is none."""
    given = os.environ.get("MUJOCO_GL")
    if given is not None:
        value = given.lower().strip()
        lib = _NEEDS.get(value)
        if value in _OFF or (value in _HARMLESS and value) or (lib and _loads(lib)):
            if lib:
                os.environ.setdefault("PYOPENGL_PLATFORM", value)
            return value
        why = f"its library (lib{lib}) is not installed" if lib else "MuJoCo does not know it"
        print(f"robotrial: ignoring MUJOCO_GL={given}: {why}", file=sys.stderr)
        del os.environ["MUJOCO_GL"]
        if os.environ.get("PYOPENGL_PLATFORM", "").lower() == value:
            del os.environ["PYOPENGL_PLATFORM"]
    for value, lib in _NEEDS.items():
        if _loads(lib):
            os.environ["MUJOCO_GL"] = value
            os.environ.setdefault("PYOPENGL_PLATFORM", value)
            return value
    return None
