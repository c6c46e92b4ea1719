"""Corpus: robots from PyPI's pybullet_data load as ROS loads them, convert to MJCF that
simulates and to RDTF that the Khronos validator passes; what ROS's URDF parser refuses
is refused with the file, the line and the element. A representative subset runs here
(the whole folder is measured in docs/urdf.md)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pybullet_data
import pytest

from robotrial.model import load_robot
from robotrial.model.rdtf import write_rdtf
from robotrial.model.robot import ModelError

from .test_corpus import convert
from .test_corpus_rdtf import start_validator

ROOT = Path(pybullet_data.getDataPath())
# robots of several kinds, and files that need a leniency ROS has (XML version 0.0,
# blank lines before the declaration, a NUL after </robot>, two shapes in a <geometry>,
# $(optenv) left in an attribute)
LOADS = {
    "racecar/racecar.urdf": "the first, <mesh>, is used",
    "husky/husky.urdf": "$(optenv HUSKY_IMU_XYZ ...) was never expanded",
    "bicycle/bike.urdf": "XML version '0.0' read as 1.0",
    "differential/diff_ring.urdf": "blank lines before the XML declaration removed",
    "kuka_iiwa/model.urdf": "",
    "r2d2.urdf": "",
    "quadruped/minitaur.urdf": "",
    "cartpole.urdf": "",
    "table/table.urdf": "",
}
REFUSED = {
    "humanoid/humanoid.urdf": "unknown joint type 'spherical'",
    "biped/biped2d_pybullet.urdf": "lower='-1.57.' is not 1 number(s)",
    "plane_implicit.urdf": "unknown shape <plane>",
    "quadruped/microtaur/microtaur.urdf": "has 4 number(s), expected 3",
}


@pytest.mark.parametrize("name", sorted(LOADS))
def test_pybullet_robot_loads_and_simulates(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(ROOT / name)
    if LOADS[name]:
        assert any(LOADS[name] in r for r in robot.repairs), robot.repairs
    outcome = convert(ROOT / name, ROOT)
    assert outcome.converted, outcome.error
    assert outcome.fk_error < 1e-9


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_what_ros_refuses_is_refused_with_file_and_line(name):
    with pytest.raises(ModelError) as err:
        load_robot(ROOT / name)
    text = str(err.value)
    assert str(ROOT / name) in text and REFUSED[name] in text
    line = text.split(str(ROOT / name), 1)[1].split(":")[1]
    assert line.isdigit(), text


@pytest.mark.slow
def test_pybullet_robots_give_valid_rdtf(tmp_path):
    written = []
    for name in sorted(LOADS):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = load_robot(ROOT / name)
        out = tmp_path / (name.replace("/", "__") + ".glb")
        write_rdtf(model, out)
        written.append(out)
    validator = start_validator(written)
    stdout, stderr = validator.communicate()
    assert validator.returncode == 0, stderr
    for report in json.loads(stdout):
        bad = [m for m in report["messages"] if m["severity"] in ("error", "warning")]
        assert not bad, (report["file"], bad[:3])


@pytest.mark.slow
def test_every_pybullet_urdf_converts_or_names_its_fault(capsys):
    urdfs = sorted(ROOT.rglob("*.urdf"))
    assert len(urdfs) > 1000
    outcomes = [convert(u, ROOT) for u in urdfs]
    failed = [o for o in outcomes if not o.converted]
    with capsys.disabled():
        print(f"\npybullet_data: {len(outcomes) - len(failed)}/{len(outcomes)} converted")
        for o in failed:
            print(f"  {o.file}: {o.error[:160]}")
    assert not [o.file for o in failed if o.unexpected]
    assert all(o.error.strip() for o in failed)
    assert len(failed) <= 0.01 * len(outcomes), [o.file for o in failed]
