"""FollowJointTrajectory for the simulated arm, as ros2_control's trajectory controller
offers it (layer 4).

`JointTrajectoryAction` serves `/arm_controller/follow_joint_trajectory` next to a
`SimNode`: the goal's trajectory becomes the joint controller's reference (starting from
where the arm is when the first point's time is after 0), feedback follows every
/joint_states message with the desired, actual and error points, and the goal ends
SUCCESSFUL once the last point's time has passed with every joint within its goal
tolerance, GOAL_TOLERANCE_VIOLATED if it is still off after `goal_time_tolerance`,
INVALID_JOINTS / INVALID_GOAL (with a message) for goals it cannot run. Cancel holds the
arm where it is.
"""

from __future__ import annotations

import itertools
import threading

import numpy as np

from robotrial.msgs import control_msgs
from robotrial.msgs.builtin_interfaces import Duration
from robotrial.msgs.sensor_msgs import JointState
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from robotrial.ros.actions import ActionServer, GoalHandle
from robotrial.ros.bus import Node
from robotrial.sim.controllers import JointReference

DEFAULT_GOAL_TOLERANCE = 0.02  # rad (or m), when the goal gives none for a joint
DEFAULT_GOAL_TIME = 1.0  # s after the last point to settle, when the goal gives none

Result = control_msgs.FollowJointTrajectoryResult


class _Run:
    """The goal being executed: its reference and where it started."""

    def __init__(
        self, handle: GoalHandle, ref: JointReference, start: float, tol: np.ndarray, settle: float
    ) -> None:
        self.handle, self.ref, self.start, self.tol, self.settle = handle, ref, start, tol, settle


class JointTrajectoryAction:
    """The follow_joint_trajectory action of one SimNode's arm (see the module docstring)."""

    def __init__(self, node: Node, name: str = "/arm_controller/follow_joint_trajectory") -> None:
        self.node = node
        self.sim = node.sim
        self.joints: list[str] = list(self.sim.joints.names) if self.sim.joints else []
        self._run: _Run | None = None
        self._guard = threading.Lock()
        self.server = ActionServer(
            node.bus,
            name,
            control_msgs.FollowJointTrajectory,
            self._execute,
            self._cancel,
            node=node.name,
        )
        node._handles.append(self.server)
        node.create_subscription("/joint_states", JointState, self._on_joint_states)

    def _invalid(self, handle: GoalHandle, code: int, why: str) -> None:
        handle.abort(Result(error_code=code, error_string=why), why)

    def _execute(self, handle: GoalHandle) -> None:
        traj: JointTrajectory = handle.goal.trajectory
        names = list(traj.joint_names)
        unknown = [n for n in names if n not in self.joints]
        if not names or unknown or len(set(names)) != len(names):
            why = (
                f"unknown joints {unknown}; this controller drives {self.joints}"
                if unknown
                else f"joint_names must name each joint once, got {names}"
            )
            self._invalid(handle, control_msgs.INVALID_JOINTS, why)
            return
        if not traj.points:
            self._invalid(handle, control_msgs.INVALID_GOAL, "the trajectory has no points")
            return
        for i, p in enumerate(traj.points):
            if len(p.positions) != len(names):
                why = f"points[{i}] has {len(p.positions)} positions for {len(names)} joints"
                self._invalid(handle, control_msgs.INVALID_GOAL, why)
                return
        times = [p.time_from_start.to_sec() for p in traj.points]
        if any(b <= a for a, b in itertools.pairwise(times)) or times[0] < 0:
            why = f"time_from_start must be >= 0 and increase strictly, got {times}"
            self._invalid(handle, control_msgs.INVALID_GOAL, why)
            return
        pos = np.array([p.positions for p in traj.points], dtype=float)
        with self.node._lock:
            current = self.sim.joint_values()
            if times[0] > 0:  # start from where the arm is, as the ros2_control one does
                times = [0.0, *times]
                pos = np.vstack([[current[n] for n in names], pos])
            ref = JointReference(names, times, pos)
            self.sim.follow(ref)
            start = self.sim.world.time
        given = {t.name: t.position for t in handle.goal.goal_tolerance if t.position > 0}
        tol = np.array([given.get(n, DEFAULT_GOAL_TOLERANCE) for n in names])
        settle = handle.goal.goal_time_tolerance.to_sec() or DEFAULT_GOAL_TIME
        with self._guard:
            old, self._run = self._run, _Run(handle, ref, start, tol, settle)
        if old is not None:
            self._invalid(old.handle, control_msgs.INVALID_GOAL, "preempted by a new goal")

    def _cancel(self, handle: GoalHandle) -> None:
        with self._guard:
            if self._run is not None and self._run.handle is handle:
                self._run = None
        with self.node._lock:
            self.sim.joints.hold(self.sim.world.data)
        handle.canceled(Result(error_string="canceled; the arm holds its position"))

    def _on_joint_states(self, msg: JointState) -> None:
        run = self._run
        if run is None or not run.handle.active:
            return
        values = dict(zip(msg.name, msg.position, strict=False))
        t = msg.header.stamp.to_sec() - run.start
        desired, vel, _ = run.ref.sample(t)
        actual = np.array([values.get(n, np.nan) for n in run.ref.names])
        error = desired - actual
        run.handle.feedback(
            control_msgs.FollowJointTrajectoryFeedback(
                header=Header(stamp=msg.header.stamp),
                joint_names=list(run.ref.names),
                desired=JointTrajectoryPoint(
                    positions=desired.tolist(),
                    velocities=vel.tolist(),
                    time_from_start=Duration.from_sec(max(t, 0.0)),
                ),
                actual=JointTrajectoryPoint(positions=actual.tolist()),
                error=JointTrajectoryPoint(positions=error.tolist()),
            )
        )
        if t < run.ref.t1:
            return
        final = np.abs(run.ref.q_end - actual)
        if np.all(final <= run.tol):
            self._end(run)
            run.handle.succeed(Result(error_code=control_msgs.SUCCESSFUL))
        elif t > run.ref.t1 + run.settle:
            worst = int(np.argmax(final - run.tol))
            why = (
                f"joint {run.ref.names[worst]} is {final[worst]:.3f} from its goal "
                f"(tolerance {run.tol[worst]:.3f}) {run.settle:.1f} s after the last point"
            )
            self._end(run)
            self._invalid(run.handle, control_msgs.GOAL_TOLERANCE_VIOLATED, why)

    def _end(self, run: _Run) -> None:
        with self._guard:
            if self._run is run:
                self._run = None
