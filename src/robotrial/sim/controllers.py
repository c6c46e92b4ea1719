"""Controllers of the simulated robot: arm joints, the mobile base, the gripper (layer 2).

All three write generalized forces (MjData.qfrc_applied), so they work whatever actuators
the MJCF holds: the arm by computed torque with gravity compensation (it tracks a
joint trajectory), the base by a velocity loop on its planar joints (base_x, base_y,
base_yaw) that follows a body twist under acceleration and speed limits, and the gripper
by pushing its fingers toward an opening with a bounded force.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline


def joint_dof(model: mujoco.MjModel, name: str, where: str = "") -> tuple[int, int]:
    """(qpos address, dof address) of a one-DOF joint, with a clear error if it is absent."""
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
    if jid < 0:
        raise ValueError(f"{where or 'sim'}: no joint {name!r} in the MuJoCo model")
    if int(model.jnt_type[jid]) not in (
        int(mujoco.mjtJoint.mjJNT_HINGE),
        int(mujoco.mjtJoint.mjJNT_SLIDE),
    ):
        raise ValueError(f"{where or 'sim'}: joint {name!r} is not a one-DOF joint")
    return int(model.jnt_qposadr[jid]), int(model.jnt_dofadr[jid])


class JointReference:
    """A joint trajectory as a smooth function of time: positions (N, d) at `times` (N,),
    optionally velocities and accelerations (as trajectory_msgs/JointTrajectory carries).

    With velocities it is a cubic Hermite spline; without, a cubic spline that starts and
    ends at rest. Before the first point and after the last it holds still."""

    def __init__(
        self,
        names: Sequence[str],
        times: Sequence[float],
        positions: np.ndarray,
        velocities: np.ndarray | None = None,
    ) -> None:
        t = np.asarray(times, dtype=float)
        q = np.asarray(positions, dtype=float).reshape(len(t), -1)
        if q.shape[1] != len(names):
            raise ValueError(
                f"joint reference: {len(names)} joint names but {q.shape[1]} values per point"
            )
        if len(t) == 0:
            raise ValueError("joint reference: no points")
        if np.any(np.diff(t) <= 0):
            raise ValueError("joint reference: time_from_start must increase strictly")
        self.names = list(names)
        self.t0 = float(t[0])
        self.t1 = float(t[-1])
        self.q_end = q[-1].copy()
        self.q_start = q[0].copy()
        if len(t) == 1:
            self._spline = None
        elif velocities is not None and np.size(velocities) == q.size:
            self._spline = CubicHermiteSpline(t, q, np.asarray(velocities, float).reshape(q.shape))
        else:
            self._spline = CubicSpline(t, q, bc_type="clamped")

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration at time `t` (s from the start)."""
        d = len(self.names)
        if self._spline is None or t >= self.t1:
            return self.q_end.copy(), np.zeros(d), np.zeros(d)
        if t <= self.t0:
            return self.q_start.copy(), np.zeros(d), np.zeros(d)
        s = self._spline
        return s(t), s(t, 1), s(t, 2)


class JointController:
    """Computed-torque joint position control with gravity compensation:
    tau = bias(q, qd) - passive(q, qd) + M(q) (qdd_ref + kp (q_ref - q) + kd (qd_ref - qd)),
    clipped to the joints' effort limits. Tracks a `JointReference`, or holds targets."""

    def __init__(
        self,
        model: mujoco.MjModel,
        joints: Sequence[str],
        kp: float = 900.0,
        kd: float = 60.0,
        effort: Sequence[float] | None = None,
    ) -> None:
        self.model = model
        self.names = list(joints)
        addr = [joint_dof(model, n, "joint controller") for n in self.names]
        self.qadr = np.array([a for a, _ in addr], dtype=int)
        self.dadr = np.array([b for _, b in addr], dtype=int)
        self.kp, self.kd = float(kp), float(kd)
        eff = np.full(len(self.names), np.inf) if effort is None else np.asarray(effort, float)
        self.effort = np.where(eff > 0, eff, np.inf)
        self.target = np.zeros(len(self.names))
        self._index = {n: i for i, n in enumerate(self.names)}
        self._ref: JointReference | None = None
        self._ref_idx = np.zeros(0, dtype=int)
        self._ref_start = 0.0
        self._acc = np.zeros(model.nv)
        self._macc = np.zeros(model.nv)

    def hold(self, data: mujoco.MjData) -> None:
        """Hold the current positions."""
        self.target = data.qpos[self.qadr].copy()
        self._ref = None

    def set_targets(self, values: dict[str, float]) -> None:
        """Move some joints to fixed positions (a step; the gains shape the motion)."""
        for n, v in values.items():
            if n not in self._index:
                raise ValueError(f"joint controller: no joint {n!r}; it drives {self.names}")
            self.target[self._index[n]] = float(v)

    def follow(self, reference: JointReference, start_time: float) -> None:
        """Track `reference`, its time 0 at simulation time `start_time`."""
        unknown = [n for n in reference.names if n not in self._index]
        if unknown:
            raise ValueError(f"joint reference names joints {unknown} this robot does not drive")
        self._ref = reference
        self._ref_idx = np.array([self._index[n] for n in reference.names], dtype=int)
        self._ref_start = float(start_time)

    @property
    def done_at(self) -> float:
        """Simulation time at which the current reference ends (-inf without one)."""
        return -np.inf if self._ref is None else self._ref_start + self._ref.t1

    def reference(self, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = self.target.copy()
        qd = np.zeros_like(q)
        qdd = np.zeros_like(q)
        if self._ref is not None:
            rq, rqd, rqdd = self._ref.sample(time - self._ref_start)
            q[self._ref_idx], qd[self._ref_idx], qdd[self._ref_idx] = rq, rqd, rqdd
            if time - self._ref_start >= self._ref.t1:
                self.target[self._ref_idx] = rq
        return q, qd, qdd

    def apply(self, data: mujoco.MjData, time: float, hold: float = 0.0) -> None:
        """Write this controller's torques into data.qfrc_applied; they stay applied for
        `hold` seconds, so the reference is taken at the middle of that interval."""
        q_ref, qd_ref, qdd_ref = self.reference(time + 0.5 * hold)
        q = data.qpos[self.qadr]
        qd = data.qvel[self.dadr]
        acc = qdd_ref + self.kp * (q_ref - q) + self.kd * (qd_ref - qd)
        self._acc[self.dadr] = acc
        mujoco.mj_mulM(self.model, data, self._macc, self._acc)
        tau = data.qfrc_bias[self.dadr] - data.qfrc_passive[self.dadr] + self._macc[self.dadr]
        data.qfrc_applied[self.dadr] = np.clip(tau, -self.effort, self.effort)


TRACTION = 3.0


@dataclass(frozen=True)
class DriveLimits:
    """A base's top speeds (m/s, rad/s) and accelerations (m/s^2, rad/s^2)."""

    max_speed: float = 1.0
    max_yaw_rate: float = 2.0
    max_accel: float = 1.0
    max_yaw_accel: float = 3.0

    def __post_init__(self) -> None:
        for k in ("max_speed", "max_yaw_rate", "max_accel", "max_yaw_accel"):
            if not getattr(self, k) > 0:
                raise ValueError(f"drive: {k} must be positive, got {getattr(self, k)}")

    @staticmethod
    def from_metadata(drive: dict) -> DriveLimits:
        keys = DriveLimits.__dataclass_fields__
        return DriveLimits(**{k: float(v) for k, v in drive.items() if k in keys})


class BaseController:
    """A skid-steer (differential) base following a body twist (v forward, w yaw rate).

    The command is rate-limited to the accelerations, clipped to the top speeds, and
    tracked by a velocity loop on the planar joints base_x, base_y, base_yaw (the sideways
    speed is held at zero: a skid-steer base cannot move sideways). The loop's force is
    capped at TRACTION times what the top acceleration needs, so the base stalls against
    a wall instead of pushing through it. Wheel joints, if named, spin at the speeds that
    motion asks for."""

    def __init__(
        self,
        model: mujoco.MjModel,
        limits: DriveLimits = DriveLimits(),
        wheels: dict[str, float] | None = None,
        wheel_radius: float = 0.165,
        time_constant: float | None = None,
    ) -> None:
        self.model = model
        self.limits = limits
        addr = [joint_dof(model, n, "base controller") for n in ("base_x", "base_y", "base_yaw")]
        self.qadr = np.array([a for a, _ in addr])
        self.dadr = np.array([b for _, b in addr])
        self.tau = time_constant or 5 * model.opt.timestep
        self._dofs = [int(d) for d in self.dadr]
        self._qyaw = int(self.qadr[2])
        self._mass = [float(m) for m in model.dof_M0[self.dadr]]
        # what the wheels can push with: TRACTION times the force of the top acceleration
        accel = (limits.max_accel, limits.max_accel, limits.max_yaw_accel)
        self._traction = [TRACTION * m * a for m, a in zip(self._mass, accel, strict=True)]
        self.wheels = [
            (joint_dof(model, n, "base controller")[1], y) for n, y in (wheels or {}).items()
        ]
        self.wheel_radius = wheel_radius
        self.command = (0.0, 0.0)
        self.velocity = (0.0, 0.0)

    def set_command(self, v: float, w: float) -> None:
        """The wanted forward speed (m/s) and yaw rate (rad/s), e.g. from geometry_msgs/Twist."""
        if not (np.isfinite(v) and np.isfinite(w)):
            raise ValueError(f"base command must be finite, got v={v}, w={w}")
        self.command = (float(v), float(w))

    def apply(self, data: mujoco.MjData, dt: float) -> None:
        """Advance the rate-limited velocity by `dt` and write the base forces."""
        lim = self.limits
        cv, cw = self.command
        goal_v = min(max(cv, -lim.max_speed), lim.max_speed)
        goal_w = min(max(cw, -lim.max_yaw_rate), lim.max_yaw_rate)
        v, w = self.velocity
        dv, dw = lim.max_accel * dt, lim.max_yaw_accel * dt
        v += min(max(goal_v - v, -dv), dv)
        w += min(max(goal_w - w, -dw), dw)
        self.velocity = (v, w)
        yaw = data.qpos[self._qyaw]
        want = (v * math.cos(yaw), v * math.sin(yaw), w)
        qvel, bias, out = data.qvel, data.qfrc_bias, data.qfrc_applied
        for i, dof in enumerate(self._dofs):
            push = self._mass[i] * (want[i] - qvel[dof]) / self.tau
            out[dof] = bias[dof] + min(max(push, -self._traction[i]), self._traction[i])
        for dof, y in self.wheels:
            qvel[dof] = (v - w * y) / self.wheel_radius


class Gripper:
    """A parallel gripper as a real one is driven (control_msgs/GripperCommand): its
    fingers go toward a `position` (the finger joint's value) pushing with at most
    `max_effort` N, so closing on an object squeezes it with that force and stops there.

    The fingers are MuJoCo position actuators (sim/build.py makes them), so the servo and
    its force limit act at every physics step. Nothing is attached: an object stays in the
    hand only by the friction of the finger contacts (sim/build.py gives them elliptic
    cones and torsional friction); a finger that mimics another follows it by MuJoCo's
    joint equality, as the description says."""

    def __init__(
        self,
        model: mujoco.MjModel,
        fingers: Sequence[str],
        open_value: float,
        closed_value: float,
        max_effort: float = 20.0,
    ) -> None:
        if not fingers:
            raise ValueError("gripper: no finger joints")
        self.model = model
        self.fingers = list(fingers)
        self.open_value, self.closed_value = float(open_value), float(closed_value)
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f) for f in self.fingers]
        if min(ids) < 0:
            raise ValueError(f"gripper: no actuator for the fingers {self.fingers} in the model")
        self._act = np.array(ids, dtype=int)
        self._q = np.array([joint_dof(model, f, "gripper")[0] for f in self.fingers], dtype=int)
        self.effort_limit = float(np.max(np.abs(model.actuator_forcerange[self._act])))
        if not self.effort_limit > 0:
            self.effort_limit = np.inf
        self.target = self.open_value
        self.max_effort = self.effort_limit
        self.command(self.open_value, max_effort)

    def command(self, position: float, max_effort: float | None = None) -> None:
        """Move every finger toward `position` with at most `max_effort` N (None: as
        before; 0 or less: the joint's own limit)."""
        if not np.isfinite(position):
            raise ValueError(f"gripper: position must be finite, got {position}")
        lo, hi = sorted((self.open_value, self.closed_value))
        self.target = min(max(float(position), lo), hi)
        if max_effort is not None:
            e = float(max_effort)
            self.max_effort = min(e, self.effort_limit) if e > 0 else self.effort_limit
        self.model.actuator_forcelimited[self._act] = 1
        self.model.actuator_forcerange[self._act] = (-self.max_effort, self.max_effort)

    def opening(self, data: mujoco.MjData) -> float:
        """The first finger joint's value (m for prismatic fingers)."""
        return float(data.qpos[self._q[0]])

    def apply(self, data: mujoco.MjData) -> None:
        """Set the finger actuators' targets (each control period)."""
        data.ctrl[self._act] = self.target
