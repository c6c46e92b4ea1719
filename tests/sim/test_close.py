"""A Simulation is a context manager, and a closed one refuses to step instead of
stepping on released sensors."""

from __future__ import annotations

import pytest

from robotrial.sim.simulation import SimOptions, StreamSettings


def test_closed_simulation_does_not_step(boxroom) -> None:
    options = SimOptions(cameras=False, streams={"lidar": StreamSettings(enabled=False)})
    with boxroom.make_sim(options=options) as sim:
        assert sim.step(5)
    assert sim.closed
    with pytest.raises(ValueError, match="is closed"):
        sim.step()
    with pytest.raises(ValueError, match="is closed"):
        sim.advance(0.1)
