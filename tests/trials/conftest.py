"""The carry trial run once per session (cup to the bedroom, seed 0), behind the wall: while
it runs, every world loaded by name, file or text has its objects and furniture at NaN
(the world side loaded the true one before), and the robot side's subscriptions are
recorded. tests/trials/test_carry.py checks the run."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

import robotrial.model
import robotrial.model.world as world_module
from robotrial.geometry import Pose
from robotrial.model.world import World
from robotrial.trials.carry import CarryResult, CarrySetup, CarryTrial, write_outputs

WORLD_SIDE = ("/simulator", "/world", "/recorder")


def without_poses(world: World) -> World:
    """The world with every object and piece of furniture at NaN."""
    lost = Pose((float("nan"),) * 3)
    return dataclasses.replace(
        world,
        obstacles=tuple(dataclasses.replace(o, pose=lost) for o in world.obstacles),
        objects=tuple(dataclasses.replace(o, pose=lost) for o in world.objects),
    )


@dataclass
class WalledRun:
    result: CarryResult
    out: Path
    trial: CarryTrial
    subscriptions: dict[str, set[str]] = field(default_factory=dict)
    worlds_loaded: int = 0


@pytest.fixture(scope="session")
def cup_to_bedroom(tmp_path_factory: pytest.TempPathFactory) -> WalledRun:
    out = tmp_path_factory.mktemp("carry")
    trial = CarryTrial(CarrySetup(object="cup", to="bedroom"), 0, out)
    run = WalledRun(CarryResult(0, False), out, trial)
    patch = pytest.MonkeyPatch()
    for module, name in (
        (robotrial.model, "load_world"),
        (world_module, "load_world_file"),
        (world_module, "load_world_text"),
        (world_module, "world_from_dict"),
    ):
        real = getattr(module, name)

        def poisoned(*args, _real=real, **kwargs):
            run.worlds_loaded += 1
            return without_poses(_real(*args, **kwargs))

        patch.setattr(module, name, poisoned)

    def record(_phase: str, _t: float) -> None:
        bus = trial.bus
        for node in bus.nodes():
            if node.startswith(WORLD_SIDE):
                continue
            subs = set(bus.node_details(node).get("subscribing", []))
            run.subscriptions.setdefault(node, set()).update(subs)

    try:
        run.result = trial.run(record)
    finally:
        patch.undo()
    write_outputs(trial, run.result, out)
    assert not np.isnan(run.result.sim_time)
    return run
