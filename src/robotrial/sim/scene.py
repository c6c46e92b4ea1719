"""SimWorld: a compiled MuJoCo model, its state and the simulation clock (layer 2).

The physics loop steps at a fixed timestep; `time` is simulated seconds. Nothing here
knows about sensors, topics or wall time: the loop runs as fast as the CPU allows, and
`Pacer` slows a caller down to real time when asked.
"""

from __future__ import annotations

import time as _time

import mujoco
import numpy as np

from robotrial.geometry import Pose

BASE_JOINTS = ("base_x", "base_y", "base_yaw")
STATE_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION


class SimWorld:
    """Wraps MjModel/MjData: reset, spawn at a pose, step N, get/set state.

    `seed` drives every random number the simulation draws (sensor noise, odometry slip)
    through `rng`; the physics itself is deterministic, so a seed fixes a run.
    """

    def __init__(self, model: mujoco.MjModel, seed: int = 0, base_body: str = "") -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.seed = int(seed)
        self.rng = np.random.default_rng(self.seed)
        self.dt = float(model.opt.timestep)
        self.planar = all(
            mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) >= 0 for n in BASE_JOINTS
        )
        self._base_q = (
            [
                int(model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)])
                for n in BASE_JOINTS
            ]
            if self.planar
            else []
        )
        self.base_body = -1
        if base_body:
            self.base_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, base_body)
            if self.base_body < 0:
                raise ValueError(f"sim: no body {base_body!r} in the MuJoCo model")
        self._initial = self.get_state()
        mujoco.mj_forward(model, self.data)

    @property
    def time(self) -> float:
        """Simulated time (s) since the last reset."""
        return float(self.data.time)

    def reset(self, seed: int | None = None) -> None:
        """Back to the state at construction (or the last `spawn`), the clock at 0."""
        if seed is not None:
            self.seed = int(seed)
        self.rng = np.random.default_rng(self.seed)
        mujoco.mj_resetData(self.model, self.data)
        self.set_state(self._initial)
        self.data.time = 0.0
        mujoco.mj_forward(self.model, self.data)

    def step(self, n: int = 1) -> None:
        """Advance the physics `n` timesteps with the forces currently applied."""
        if n < 0:
            raise ValueError(f"sim: cannot step a negative number of steps ({n})")
        if n:
            mujoco.mj_step(self.model, self.data, nstep=int(n))

    def forward(self) -> None:
        """Recompute positions, contacts and sensors for the current state without stepping."""
        mujoco.mj_forward(self.model, self.data)

    def get_state(self) -> np.ndarray:
        """The full integration state (time, qpos, qvel, act, controls, applied forces...)."""
        size = mujoco.mj_stateSize(self.model, STATE_SPEC)
        out = np.empty(size)
        mujoco.mj_getState(self.model, self.data, out, STATE_SPEC)
        return out

    def set_state(self, state: np.ndarray) -> None:
        size = mujoco.mj_stateSize(self.model, STATE_SPEC)
        s = np.asarray(state, dtype=float)
        if s.shape != (size,):
            raise ValueError(f"sim: a state has {size} numbers for this model, got {s.shape}")
        mujoco.mj_setState(self.model, self.data, s, STATE_SPEC)
        mujoco.mj_forward(self.model, self.data)

    def spawn(self, pose: Pose) -> None:
        """Put the robot's base at `pose` (planar: x, y, yaw; free root: the full pose),
        at rest, and make that the state `reset` returns to."""
        if self.planar:
            x, y, _ = pose.xyz
            for adr, v in zip(self._base_q, (x, y, pose.yaw), strict=True):
                self.data.qpos[adr] = v
        elif self.base_body >= 0 and self.model.body_jntadr[self.base_body] >= 0:
            jadr = self.model.body_jntadr[self.base_body]
            if int(self.model.jnt_type[jadr]) != int(mujoco.mjtJoint.mjJNT_FREE):
                raise ValueError("sim: the robot's root is neither planar nor free; it cannot move")
            qa = self.model.jnt_qposadr[jadr]
            x, y, z, w = pose.quat
            self.data.qpos[qa : qa + 3] = pose.xyz
            self.data.qpos[qa + 3 : qa + 7] = (w, x, y, z)
        else:
            raise ValueError("sim: the robot's base is fixed; build it with a planar or free base")
        self.data.qvel[:] = 0.0
        mujoco.mj_forward(self.model, self.data)
        self._initial = self.get_state()

    def body_pose(self, body: int | str) -> np.ndarray:
        """World 4x4 pose of a body (by id or name)."""
        bid = body if isinstance(body, int) else self.body_id(body)
        m = np.eye(4)
        m[:3, :3] = self.data.xmat[bid].reshape(3, 3)
        m[:3, 3] = self.data.xpos[bid]
        return m

    def body_id(self, name: str) -> int:
        bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if bid < 0:
            raise ValueError(f"sim: no body {name!r} in the MuJoCo model")
        return bid

    def base_pose2d(self) -> tuple[float, float, float]:
        """The base's true x, y (m) and yaw (rad) in the world frame."""
        if self.planar:
            q = self.data.qpos
            return float(q[self._base_q[0]]), float(q[self._base_q[1]]), float(q[self._base_q[2]])
        m = self.body_pose(max(self.base_body, 0))
        return float(m[0, 3]), float(m[1, 3]), float(np.arctan2(m[1, 0], m[0, 0]))

    def is_finite(self) -> bool:
        """No NaN or inf in positions, velocities or accelerations."""
        d = self.data
        return bool(
            np.all(np.isfinite(d.qpos))
            and np.all(np.isfinite(d.qvel))
            and np.all(np.isfinite(d.qacc))
        )


class Pacer:
    """Keeps a loop at `factor` times real time (None: as fast as possible)."""

    def __init__(self, factor: float | None = None) -> None:
        if factor is not None and not factor > 0:
            raise ValueError(f"pacing factor must be positive, got {factor}")
        self.factor = factor
        self._start_wall = _time.perf_counter()
        self._start_sim: float | None = None

    def wait(self, sim_time: float) -> None:
        if self.factor is None:
            return
        if self._start_sim is None:
            self._start_sim = sim_time
            self._start_wall = _time.perf_counter()
            return
        due = self._start_wall + (sim_time - self._start_sim) / self.factor
        delay = due - _time.perf_counter()
        if delay > 0:
            _time.sleep(delay)
