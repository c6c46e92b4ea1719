"""The public Python API: `import robotrial` is cheap, and every example in
docs/python.md runs as written."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import robotrial

DOC = Path(__file__).resolve().parents[1] / "docs" / "python.md"
EXAMPLES = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


def test_importing_robotrial_loads_no_simulator() -> None:
    code = "import sys, robotrial; print('mujoco' in sys.modules, 'numba' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.stdout.split() == ["False", "False"], done.stderr


def test_the_public_names_resolve_and_unknown_ones_are_named() -> None:
    for name in robotrial.__all__:
        assert getattr(robotrial, name) is not None
    with pytest.raises(AttributeError, match="no attribute 'Simulator'"):
        _ = robotrial.Simulator


@pytest.mark.parametrize("code", EXAMPLES, ids=[f"example {i + 1}" for i in range(len(EXAMPLES))])
def test_every_example_in_the_docs_runs(code: str, tmp_path: Path) -> None:
    assert len(EXAMPLES) == 6
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]


def test_numba_starts_without_scipy_linalg_and_still_compiles_blas_calls() -> None:
    # numba's array module probes BLAS by importing the whole of scipy.linalg; robotrial
    # answers the probe, and a kernel that calls BLAS loads it when it compiles
    code = (
        "import sys, robotrial, numba, numpy as np\n"
        "import numba.np.arraymath as am\n"
        "print('scipy.linalg' in sys.modules, am._HAVE_BLAS)\n"
        "f = numba.njit(lambda a: a @ a)\n"
        "print(f(2 * np.eye(3))[1, 1], 'scipy.linalg' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.stdout.split() == ["False", "True", "4.0", "True"], done.stderr[-500:]
