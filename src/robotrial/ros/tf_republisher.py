"""tf2_web_republisher on the bus: TF for web clients (layer 4).

Web pages (roslibjs's `TFClient` and `ROS2TFClient`, ros3djs, webviz-style viewers) do not
follow /tf themselves: they ask tf2_web_republisher for the transforms of a few frames
relative to a fixed frame, at a rate, sent only when they moved more than a threshold.
This node offers the three ways they ask:

- ROS 2 action `/tf2_web_republisher` (`tf2_web_republisher_interfaces/action/TFSubscription`,
  what roslib 2.x's ROS2TFClient sends): the transforms arrive as feedback until the
  goal is canceled;
- ROS 1 actionlib over `/tf2_web_republisher/goal`, `/cancel` and `/feedback`
  (`tf2_web_republisher/TFSubscriptionAction*`, what TFClient sends);
- ROS 2 service `/republish_tfs` (`tf2_web_republisher_interfaces/srv/RepublishTFs`): the
  answer names a new topic (`/tf_repub_N`, `TFArray`) that carries them, dropped after
  `timeout` without a subscriber.

The transforms come from /tf and /tf_static; a frame not (yet) connected to the fixed
frame is left out until it is.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robotrial.geometry import Pose
from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.geometry_msgs import Quaternion, Transform, TransformStamped, Vector3
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.msgs.tf2_web_republisher import (
    GoalID,
    GoalStatus,
    RepublishTFs,
    Ros1TFSubscriptionFeedback,
    TFArray,
    TFSubscription,
    TFSubscriptionActionFeedback,
    TFSubscriptionActionGoal,
    TFSubscriptionFeedback,
)
from robotrial.ros.actions import ActionServer, GoalHandle
from robotrial.ros.bus import Bus, Node, Timer

SERVER = "/tf2_web_republisher"
SERVICE = "/republish_tfs"
TICK = 0.02  # s between checks of what is due
MAX_RATE = 100.0  # Hz


def _strip(frame: str) -> str:
    return frame[1:] if frame.startswith("/") else frame


@dataclass
class Subscription:
    """One client's request: frames, fixed frame, thresholds, rate, and where to send."""

    frames: list[str]
    target: str
    angular_thres: float
    trans_thres: float
    period: float
    send: Any  # callable(list[TransformStamped])
    last: dict[str, Pose] = field(default_factory=dict)
    due: float = 0.0


class TfRepublisher(Node):
    """Answers TF subscriptions of web clients from the bus's /tf and /tf_static."""

    def __init__(self, bus: Bus, name: str = "/tf2_web_republisher") -> None:
        super().__init__(bus, bus.unique_node_name(name))
        self._lock = threading.RLock()  # latched /tf_static arrives inside _listen
        self._parents: dict[str, tuple[str, Pose]] = {}  # child -> (parent, parent_T_child)
        self._subs: dict[Any, Subscription] = {}
        self._topics: dict[
            str, tuple[Any, float, float]
        ] = {}  # topic -> (publisher, timeout, since)
        self._count = itertools.count(1)
        self._tf_subs: list[Any] = []  # /tf and /tf_static, only while someone asks
        self._timer: Timer | None = None
        self.action = ActionServer(
            bus, SERVER, TFSubscription, self._execute, self._cancel, self.name
        )
        self.create_subscription(f"{SERVER}/goal", TFSubscriptionActionGoal, self._on_ros1_goal)
        self.create_subscription(f"{SERVER}/cancel", GoalID, self._on_ros1_cancel)
        self._ros1_feedback: Any = None
        self.create_service(SERVICE, RepublishTFs, self._republish, threaded=False)

    # --- the TF tree --------------------------------------------------------------------

    def _on_tf(self, msg: TFMessage) -> None:
        with self._lock:
            for t in msg.transforms:
                tr, q = t.transform.translation, t.transform.rotation
                pose = Pose((tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w))
                self._parents[_strip(t.child_frame_id)] = (_strip(t.header.frame_id), pose)

    def _to_root(self, frame: str) -> tuple[str, Pose]:
        pose, seen = Pose(), set()
        while frame in self._parents and frame not in seen:
            seen.add(frame)
            parent, p = self._parents[frame]
            pose, frame = p @ pose, parent
        return frame, pose

    def lookup(self, target: str, source: str) -> Pose | None:
        """target_T_source, or None while the two frames are not connected."""
        with self._lock:
            root_a, a = self._to_root(_strip(target))
            root_b, b = self._to_root(_strip(source))
        return a.inverse() @ b if root_a == root_b else None

    # --- sending ------------------------------------------------------------------------

    def _changes(self, sub: Subscription) -> list[TransformStamped]:
        out = []
        stamp = self.bus.now()
        for frame in sub.frames:
            pose = self.lookup(sub.target, frame)
            if pose is None:
                continue
            last = sub.last.get(frame)
            if last is not None:
                moved = float(np.linalg.norm(np.subtract(pose.xyz, last.xyz)))
                dot = abs(float(np.dot(pose.quat, last.quat)))
                turned = 2 * math.acos(min(1.0, dot))
                if moved < sub.trans_thres and turned < sub.angular_thres:
                    continue
            sub.last[frame] = pose
            out.append(
                TransformStamped(
                    header=Header(stamp=Time.from_sec(stamp), frame_id=sub.target),
                    child_frame_id=frame,
                    transform=Transform(
                        translation=Vector3(*pose.xyz), rotation=Quaternion(*pose.quat)
                    ),
                )
            )
        return out

    def _tick(self) -> None:
        now = time.monotonic()
        for key, sub in list(self._subs.items()):
            if now < sub.due:
                continue
            sub.due = now + sub.period
            changed = self._changes(sub)
            if changed:
                sub.send(changed)
            self._expire(key, now)

    def _add(
        self,
        key: Any,
        frames: list[str],
        target: str,
        ang: float,
        trans: float,
        rate: float,
        send: Any,
    ) -> None:
        rate = min(max(rate, 0.1), MAX_RATE) if rate > 0 else 10.0
        sub = Subscription(
            [_strip(f) for f in frames], _strip(target), ang, trans, 1.0 / rate, send
        )
        self._subs[key] = sub
        self._listen()

    def _remove(self, key: Any) -> None:
        self._subs.pop(key, None)
        if not self._subs:
            self._stop_listening()

    def _listen(self) -> None:
        """Follow /tf and /tf_static and start sending (the simulator only builds /tf
        messages while someone subscribes, so this waits for a client)."""
        with self._lock:
            if self._timer is not None:
                return
            self._tf_subs = [
                self.bus.subscribe(t, self._on_tf, TFMessage, node=self.name)
                for t in ("/tf", "/tf_static")
            ]
            self._timer = Timer(TICK, self._tick, name=f"{self.name} timer")

    def _stop_listening(self) -> None:
        with self._lock:
            timer, self._timer = self._timer, None
            subs, self._tf_subs = self._tf_subs, []
            self._parents.clear()
        for sub in subs:
            sub.close()
        if timer is not None:
            timer.cancel()

    # --- ROS 2 action -------------------------------------------------------------------

    def _execute(self, handle: GoalHandle) -> None:
        g = handle.goal
        self._add(
            handle.id,
            g.source_frames,
            g.target_frame,
            g.angular_thres,
            g.trans_thres,
            g.rate,
            lambda ts, h=handle: h.feedback(TFSubscriptionFeedback(transforms=ts)),
        )

    def _cancel(self, handle: GoalHandle) -> None:
        self._remove(handle.id)
        handle.canceled(TFSubscription.Result())

    # --- ROS 1 actionlib ----------------------------------------------------------------

    def _on_ros1_goal(self, msg: TFSubscriptionActionGoal) -> None:
        goal_id = msg.goal_id
        if self._ros1_feedback is None:
            self._ros1_feedback = self.create_publisher(
                f"{SERVER}/feedback", TFSubscriptionActionFeedback
            )

        def send(ts: list[TransformStamped]) -> None:
            status = GoalStatus(goal_id=goal_id, status=GoalStatus.ACTIVE)
            feedback = Ros1TFSubscriptionFeedback(transforms=ts)
            self._ros1_feedback.publish(
                TFSubscriptionActionFeedback(status=status, feedback=feedback)
            )

        g = msg.goal
        self._add(
            ("ros1", goal_id.id),
            g.source_frames,
            g.target_frame,
            g.angular_thres,
            g.trans_thres,
            g.rate,
            send,
        )

    def _on_ros1_cancel(self, msg: GoalID) -> None:
        """actionlib's cancel: one goal by id, or every goal when the id is empty."""
        for key in [k for k in self._subs if isinstance(k, tuple) and k[0] == "ros1"]:
            if not msg.id or key[1] == msg.id:
                self._remove(key)

    # --- ROS 2 service ------------------------------------------------------------------

    def _republish(self, req: Any) -> Any:
        topic = f"/tf_repub_{next(self._count)}"
        pub = self.create_publisher(topic, TFArray)
        timeout = req.timeout.to_sec() or 10.0
        self._topics[topic] = (pub, timeout, time.monotonic())
        self._add(
            topic,
            req.source_frames,
            req.target_frame,
            req.angular_thres,
            req.trans_thres,
            req.rate,
            lambda ts, p=pub: p.publish(TFArray(transforms=ts)),
        )
        return RepublishTFs.Response(topic_name=topic)

    def _expire(self, key: Any, now: float) -> None:
        """Drop a /republish_tfs topic nobody has listened to for its timeout."""
        if key not in self._topics:
            return
        pub, timeout, since = self._topics[key]
        if self.bus.subscriber_count(key):
            self._topics[key] = (pub, timeout, now)
        elif now - since > timeout:
            del self._topics[key]
            self._remove(key)
            pub.close()

    def destroy(self) -> None:
        self._subs.clear()
        self._stop_listening()
        self.action.close()
        super().destroy()
