"""Corpus: every URDF that example-robot-data ships converts to MJCF and simulates.

Each file either converts (the MJCF compiles in MuJoCo, its body poses equal the
reference FK at random joint values, and one second of simulation with the base fixed
and the motors off stays finite and stable) or fails with a ModelError
that names the cause. At least 95% must convert. Counts are printed and written to
test-artifacts/corpus_mjcf.json.
"""

from __future__ import annotations

import json
import time
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import mujoco
import numpy as np
import pytest

from robotrial.kinematics.reference import joint_values, link_poses
from robotrial.model import load_robot
from robotrial.model.mjcf import to_mjcf
from robotrial.model.robot import ModelError, RobotModel

SIM_SECONDS = 1.0
MIN_CONVERTED = 0.95


@dataclass
class Outcome:
    file: str
    converted: bool
    error: str = ""
    bodies: int = 0
    meshes: int = 0
    notes: int = 0
    seconds: float = 0.0
    fk_error: float = 0.0  # m or rad: MuJoCo's link poses against the reference FK
    unexpected: bool = False  # an exception other than ModelError: a bug, not a bad file


def simulate(model: mujoco.MjModel, seconds: float) -> str:
    """Step with zero controls; '' if the state stayed finite and stable, else why not."""
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, round(seconds / model.opt.timestep))
    bad = data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
    if bad or not np.all(np.isfinite(data.qpos)) or not np.all(np.isfinite(data.qvel)):
        return f"simulation diverged (bad accelerations {bad} times, t={data.time:.3f} s)"
    return ""


def fk_error(robot: RobotModel, model: mujoco.MjModel, samples: int = 2) -> float:
    """Largest difference between MuJoCo's body poses and link_poses at random joint values."""
    data = mujoco.MjData(model)
    lo, hi = robot.joint_limits()
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(samples):
        q = rng.uniform(lo, hi)
        for name, value in joint_values(robot, q).items():
            if robot.joint(name).type != "fixed":  # a mimic tag on a fixed joint: no motion
                data.qpos[model.joint(name).qposadr[0]] = value
        mujoco.mj_kinematics(model, data)
        for link, pose in link_poses(robot, q).items():
            if link == "world":
                continue
            b = model.body(link).id
            worst = max(
                worst,
                float(np.abs(data.xpos[b] - pose[:3, 3]).max()),
                float(np.abs(data.xmat[b].reshape(3, 3) - pose[:3, :3]).max()),
            )
    return worst


def convert(urdf: Path, root: Path, robot: RobotModel | None = None) -> Outcome:
    """Convert `urdf` (loaded here unless `robot` is its model) to MJCF and simulate it."""
    start = time.perf_counter()
    name = str(urdf.relative_to(root))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # repairs are reported by the loader's own tests
            robot = robot or load_robot(urdf)
        doc = to_mjcf(robot, base="fixed", actuators="motor")
        model = doc.compile()
    except ModelError as exc:
        return Outcome(name, False, str(exc), seconds=time.perf_counter() - start)
    except Exception as exc:
        error = f"{type(exc).__name__}: {exc}"
        return Outcome(name, False, error, seconds=time.perf_counter() - start, unexpected=True)
    problem = simulate(model, SIM_SECONDS)
    return Outcome(
        name,
        not problem,
        problem,
        fk_error=fk_error(robot, model),
        bodies=model.nbody,
        meshes=model.nmesh,
        notes=len(doc.notes),
        seconds=time.perf_counter() - start,
    )


def test_every_example_robot_data_urdf_converts_or_names_its_fault(
    artifacts: Path, capsys: pytest.CaptureFixture[str], example_robot_data
) -> None:
    root = example_robot_data.root
    urdfs = example_robot_data.urdfs
    assert len(urdfs) >= 50, f"expected the example-robot-data corpus under {root}"
    outcomes = [
        convert(u, root, example_robot_data.models.get(u))
        if u in example_robot_data.models
        else Outcome(str(u.relative_to(root)), False, example_robot_data.refused[u])
        for u in urdfs
    ]
    done = [o for o in outcomes if o.converted]
    failed = [o for o in outcomes if not o.converted]
    (artifacts / "corpus_mjcf.json").write_text(json.dumps([asdict(o) for o in outcomes], indent=1))
    with capsys.disabled():
        print(
            f"\nMJCF corpus: {len(done)}/{len(outcomes)} converted and simulated "
            f"{SIM_SECONDS:g} s; {len(failed)} refused"
        )
        for o in failed:
            print(f"  {o.file}: {o.error[:200]}")
    assert not [o for o in failed if o.unexpected], "conversion crashed instead of refusing"
    assert not [(o.file, o.fk_error) for o in done if o.fk_error > 1e-9]
    for o in failed:
        assert o.error.strip(), f"{o.file} failed without saying why"
    assert len(done) >= MIN_CONVERTED * len(outcomes), [o.file for o in failed]
