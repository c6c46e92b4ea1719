"""Controllers of the simulated robot: arm joints, the mobile base, the gripper (layer 2).

All three write generalized forces (MjData.qfrc_applied), so they work whatever actuators
the MJCF holds: the arm by computed torque with gravity compensation (it tracks a
joint trajectory), the base by a velocity loop on its planar joints (base_x, base_y,
base_yaw) that follows a body twist under acceleration and speed limits, and the gripper
by moving its fingers and carrying a grasped object with the hand.
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
    """Opens and closes finger joints (through a JointController) and carries an object.

    `grasp` takes the nearest movable object within `reach` of the hand: from then on the
    object keeps its pose relative to the hand (its collisions are off while held);
    `release` puts it back under physics, moving with the hand's velocity."""

    def __init__(
        self,
        model: mujoco.MjModel,
        hand_body: str,
        fingers: Sequence[str] = (),
        open_value: float = 0.0,
        closed_value: float = 0.0,
        joints: JointController | None = None,
        reach: float = 0.12,
    ) -> None:
        self.model = model
        hid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, hand_body)
        if hid < 0:
            raise ValueError(f"gripper: no body {hand_body!r} in the MuJoCo model")
        self.hand = hid
        self.fingers = list(fingers)
        self.open_value, self.closed_value = float(open_value), float(closed_value)
        self.joints = joints
        self.reach = reach
        self.held: int | None = None
        self._rel = np.eye(4)
        self._saved: dict[int, tuple[int, int]] = {}
        self.objects = {}
        for b in range(model.nbody):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or ""
            jadr = model.body_jntadr[b]
            if jadr >= 0 and int(model.jnt_type[jadr]) == int(mujoco.mjtJoint.mjJNT_FREE):
                if name.startswith("object/"):
                    self.objects[name] = b

    def _pose(self, data: mujoco.MjData, body: int) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = data.xmat[body].reshape(3, 3)
        m[:3, 3] = data.xpos[body]
        return m

    def open(self, data: mujoco.MjData) -> None:
        """Open the fingers and let go of any held object."""
        if self.joints is not None and self.fingers:
            self.joints.set_targets({f: self.open_value for f in self.fingers})
        self.release(data)

    def close(self, data: mujoco.MjData) -> str | None:
        """Close the fingers; grasp the nearest object in reach. Returns its name or None."""
        if self.joints is not None and self.fingers:
            self.joints.set_targets({f: self.closed_value for f in self.fingers})
        return self.grasp(data)

    def grasp(self, data: mujoco.MjData, name: str | None = None) -> str | None:
        hand = data.xpos[self.hand]
        best, best_d = None, self.reach
        for n, b in self.objects.items():
            if name is not None and n not in (name, f"object/{name}"):
                continue
            dist = float(np.linalg.norm(data.xpos[b] - hand))
            if dist <= best_d:
                best, best_d = n, dist
        if best is None:
            return None
        b = self.objects[best]
        self.held = b
        self._rel = np.linalg.inv(self._pose(data, self.hand)) @ self._pose(data, b)
        for g in range(
            self.model.body_geomadr[b], self.model.body_geomadr[b] + self.model.body_geomnum[b]
        ):
            self._saved[g] = (int(self.model.geom_contype[g]), int(self.model.geom_conaffinity[g]))
            self.model.geom_contype[g] = 0
            self.model.geom_conaffinity[g] = 0
        return best

    def release(self, data: mujoco.MjData) -> None:
        if self.held is None:
            return
        for g, (ct, ca) in self._saved.items():
            self.model.geom_contype[g] = ct
            self.model.geom_conaffinity[g] = ca
        self._saved.clear()
        dadr = self.model.jnt_dofadr[self.model.body_jntadr[self.held]]
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, self.held, vel, 0)
        data.qvel[dadr : dadr + 3] = vel[3:]
        data.qvel[dadr + 3 : dadr + 6] = 0.0
        self.held = None

    def carry(self, data: mujoco.MjData) -> None:
        """Put the held object where the hand has taken it (call after each physics step)."""
        if self.held is None:
            return
        pose = self._pose(data, self.hand) @ self._rel
        jadr = self.model.body_jntadr[self.held]
        qadr, dadr = self.model.jnt_qposadr[jadr], self.model.jnt_dofadr[jadr]
        data.qpos[qadr : qadr + 3] = pose[:3, 3]
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, pose[:3, :3].reshape(-1))
        data.qpos[qadr + 3 : qadr + 7] = quat
        data.qvel[dadr : dadr + 6] = 0.0
