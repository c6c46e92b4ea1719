"""The navigation stack on the bus: AMCL and the navigator behind ROS topics (layer 4).

`NavNode` plays move_base + amcl. It holds no algorithm of its own: it feeds
`robotrial.nav.AMCL` and `robotrial.nav.Navigator` from messages and publishes what they
produce.

| direction | topic | type |
| --- | --- | --- |
| in | `/map` | nav_msgs/OccupancyGrid (latched; builds the costmaps and AMCL) |
| in | `/initialpose` | geometry_msgs/PoseWithCovarianceStamped (AMCL's initial guess) |
| in | `/odom` | nav_msgs/Odometry (drives the control loop at `control_rate`) |
| in | `/scan` | sensor_msgs/LaserScan (AMCL update, obstacle layers) |
| in | `/move_base_simple/goal` | geometry_msgs/PoseStamped |
| action | `/navigate_to_pose` | nav2_msgs/action/NavigateToPose |
| out | `/cmd_vel` | geometry_msgs/Twist |
| out | `/plan` | nav_msgs/Path |
| out | `/move_base/global_costmap/costmap` | nav_msgs/OccupancyGrid (on each new plan) |
| out | `/move_base/local_costmap/costmap` | nav_msgs/OccupancyGrid (on each scan) |
| out | `/amcl_pose` | geometry_msgs/PoseWithCovarianceStamped |
| out | `/particlecloud` | geometry_msgs/PoseArray |
| out | `/move_base/status` | std_msgs/String (idle, active, succeeded or aborted: why) |
| out | `/robotrial/nav_status` | robotrial_msgs/NavStatus (latched; see below) |
| out | `/local_plan` | nav_msgs/Path (the controller's next moments, as rolled out) |
| out | `/move_base/local_costmap/footprint` | geometry_msgs/PolygonStamped (latched) |

NavStatus says what the navigator does (planning, driving, recovering and with which
recovery, reached, failed or refused with the reason), the distance left along the plan
and the time since the goal; the footprint is the base's rectangle in its own frame.

A goal from either input is judged before the base moves
(`robotrial.nav.goals.check_goal`): one off the map, in or too near an obstacle, or out
of the footprint's reach is refused at once (NavStatus `refused`, the action aborted)
with the reason in words; one the base already stands on is reached at once.

A `/navigate_to_pose` goal reports the current pose, the distance left along the plan and
the recoveries run so far as feedback, and ends SUCCEEDED at the goal, ABORTED with the
navigator's reason (error_msg) when it gives up, or CANCELED (after a zero /cmd_vel) when
the client cancels. A new goal from either input preempts (aborts) the running one.

Costmap cells go out as 0..100 (costmap_2d's cost * 100 / 253, lethal 100) and -1 for
unknown.
"""

from __future__ import annotations

import threading

import numpy as np

from robotrial.msgs import nav2_msgs
from robotrial.msgs.builtin_interfaces import Duration, Time
from robotrial.msgs.geometry_msgs import (
    Point32,
    Polygon,
    PolygonStamped,
    Pose,
    PoseArray,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    Twist,
    Vector3,
)
from robotrial.msgs.nav_msgs import MapMetaData, OccupancyGrid, Odometry, Path
from robotrial.msgs.robotrial_msgs import NavStatus
from robotrial.msgs.sensor_msgs import LaserScan
from robotrial.msgs.std_msgs import Header, String
from robotrial.nav.amcl import AMCL, AMCLConfig, compose, inverse
from robotrial.nav.costmap import LETHAL, UNKNOWN, Costmap, Footprint
from robotrial.nav.goals import check_goal
from robotrial.nav.navigator import RECOVERY_WORDS, Navigator, NavigatorConfig, Status
from robotrial.ros.actions import ActionServer, GoalHandle
from robotrial.ros.bus import Bus, Node

GLOBAL_COSTMAP = "/move_base/global_costmap/costmap"
LOCAL_COSTMAP = "/move_base/local_costmap/costmap"
NAV_STATUS = "/robotrial/nav_status"
FOOTPRINT = "/move_base/local_costmap/footprint"
STATUS_PERIOD = 0.5  # s between NavStatus messages while a goal runs
LOCAL_PLAN_PERIOD = 0.2  # s between /local_plan messages


def _yaw(q: Quaternion) -> float:
    return float(np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))


def costmap_message(cm: Costmap, stamp: float, frame: str = "map") -> OccupancyGrid:
    """A costmap as nav_msgs/OccupancyGrid (0..100, -1 unknown)."""
    cost = cm.cost.astype(np.int32)
    data = np.where(cost >= LETHAL, 100, (cost * 100) // 253)
    data[cost == UNKNOWN] = -1
    rows, cols = cm.shape
    return OccupancyGrid(
        header=Header(stamp=Time.from_sec(stamp), frame_id=frame),
        info=MapMetaData(
            map_load_time=Time.from_sec(stamp),
            resolution=cm.resolution,
            width=cols,
            height=rows,
            origin=Pose.planar(cm.origin[0], cm.origin[1], 0.0),
        ),
        data=data.astype(np.int8).ravel().tolist(),
    )


class NavNode(Node):
    """AMCL + navigator on the bus (see the module docstring for the topics)."""

    def __init__(
        self,
        bus: Bus,
        footprint: Footprint,
        config: NavigatorConfig | None = None,
        amcl_config: AMCLConfig | None = None,
        laser_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
        name: str = "move_base",
        seed: int = 0,
        base_frame: str = "base_link",
    ) -> None:
        super().__init__(bus, name)
        self.footprint = footprint
        self.config = config or NavigatorConfig()
        self.amcl_config = amcl_config or AMCLConfig()
        self.laser_pose = np.asarray(laser_pose, dtype=float)
        self.seed = seed
        self.navigator: Navigator | None = None
        self.amcl: AMCL | None = None
        self.map_to_odom = np.zeros(3)
        self.odom = np.zeros(3)
        self.velocity = (0.0, 0.0)
        self._initial: tuple[np.ndarray, np.ndarray] | None = None
        # a goal waits here for the next control step: judging it plans with the
        # footprint, which must not hold up whoever published it (rosbridge's loop)
        self._incoming: PoseStamped | None = None
        self._next_control = -np.inf
        self._last_status = ""
        self._plans = 0
        self.cmd_pub = self.create_publisher("/cmd_vel", Twist)
        self.plan_pub = self.create_publisher("/plan", Path)
        self.global_pub = self.create_publisher(GLOBAL_COSTMAP, OccupancyGrid, latched=True)
        self.local_pub = self.create_publisher(LOCAL_COSTMAP, OccupancyGrid)
        self.pose_pub = self.create_publisher("/amcl_pose", PoseWithCovarianceStamped)
        self.cloud_pub = self.create_publisher("/particlecloud", PoseArray)
        self.status_pub = self.create_publisher("/move_base/status", String, latched=True)
        self.nav_status_pub = self.create_publisher(NAV_STATUS, NavStatus, latched=True)
        self.local_plan_pub = self.create_publisher("/local_plan", Path)
        self.footprint_pub = self.create_publisher(FOOTPRINT, PolygonStamped, latched=True)
        half_l, half_w = footprint.length / 2, footprint.width / 2
        corners = [(half_l, half_w), (-half_l, half_w), (-half_l, -half_w), (half_l, -half_w)]
        self.footprint_pub.publish(
            PolygonStamped(
                header=Header(frame_id=base_frame),
                polygon=Polygon(points=[Point32(x=x, y=y, z=0.0) for x, y in corners]),
            )
        )
        self._goal_msg: PoseStamped | None = None
        self._stamp = 0.0
        self._goal_since: float | None = None
        self._said = ("", "")
        self._said_at = -np.inf
        self._recoveries_said = 0
        self._local_at = -np.inf
        self.create_subscription("/map", OccupancyGrid, self._on_map)
        self.create_subscription("/initialpose", PoseWithCovarianceStamped, self._on_initial)
        self.create_subscription("/move_base_simple/goal", PoseStamped, self._on_goal)
        self.create_subscription("/odom", Odometry, self._on_odom)
        self.create_subscription("/scan", LaserScan, self._on_scan)
        self._goal: GoalHandle | None = None
        # action goals and cancels arrive on other threads than /odom's control step
        self._control = threading.RLock()
        self._goal_start = 0.0
        self._goal_recoveries = 0
        self.nav_action = ActionServer(
            bus,
            "/navigate_to_pose",
            nav2_msgs.NavigateToPose,
            self._on_action_goal,
            self._on_action_cancel,
            node=self.name,
        )
        self._handles.append(self.nav_action)

    # --- inputs ------------------------------------------------------------------------

    def _on_map(self, msg: OccupancyGrid) -> None:
        info = msg.info
        if info.width * info.height != len(msg.data):
            raise ValueError(
                f"/map: {info.width} x {info.height} cells announced, {len(msg.data)} sent"
            )
        data = np.asarray(msg.data, dtype=np.int16).reshape(info.height, info.width)
        occupied, unknown = data >= 65, data < 0
        origin = (info.origin.position.x, info.origin.position.y)
        self.navigator = Navigator(
            occupied, origin, info.resolution, self.footprint, self.config, unknown
        )
        self.amcl = AMCL(occupied, origin, info.resolution, self.amcl_config, seed=self.seed)
        mean, std = self._initial or (np.zeros(3), np.array([0.25, 0.25, 0.2]))
        self.amcl.initialize(tuple(mean), tuple(std))
        self.map_to_odom = compose(mean, inverse(self.odom))
        stamp = msg.header.stamp.to_sec()
        self.global_pub.publish(costmap_message(self.navigator.global_costmap, stamp))

    def _on_initial(self, msg: PoseWithCovarianceStamped) -> None:
        p = msg.pose.pose
        mean = np.array([p.position.x, p.position.y, _yaw(p.orientation)])
        cov = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)
        std = np.sqrt(np.maximum([cov[0, 0], cov[1, 1], cov[5, 5]], 1e-4))
        self._initial = (mean, std)
        if self.amcl is not None:
            self.amcl.initialize(tuple(mean), tuple(std))
            self.map_to_odom = compose(mean, inverse(self.odom))

    @property
    def goal_pending(self) -> bool:
        """Whether a goal came in that the next control step has yet to take up."""
        return self._incoming is not None

    def _on_goal(self, msg: PoseStamped) -> None:
        with self._control:
            self._preempt()
            self._take(msg)

    def _take(self, msg: PoseStamped) -> None:
        """Hold a new goal for the next control step."""
        self._incoming = msg
        self._goal_msg = msg
        if self.navigator is None:
            self._say("planning", "waiting for the map", -1.0, 0.0)

    def _set_goal(self, msg: PoseStamped) -> None:
        p = msg.pose
        goal = np.array([p.position.x, p.position.y, _yaw(p.orientation)])
        self._goal_msg = msg
        self._goal_since = None
        nav = self.navigator
        self._recoveries_said = len(nav.recoveries)
        verdict = check_goal(
            nav.global_costmap,
            tuple(goal),
            tuple(self.pose()),
            nav.hybrid,
            xy_tolerance=self.config.xy_tolerance,
        )
        if verdict.kind == "here":
            nav.conclude(*goal, reached=True, message=verdict.reason)
            self._say("reached", verdict.reason, 0.0, 0.0)
            if self._goal is not None and self._goal.active:
                self._goal.succeed(nav2_msgs.NavigateToPoseResult(), verdict.reason)
            return
        if not verdict.ok:
            nav.conclude(*goal, reached=False, message=verdict.reason)
            self._say("refused", verdict.reason, -1.0, 0.0)
            if self._goal is not None and self._goal.active:
                result = nav2_msgs.NavigateToPoseResult(
                    error_code=nav2_msgs.UNKNOWN, error_msg=verdict.reason
                )
                self._goal.abort(result, verdict.reason)
            return
        nav.set_goal(*goal, now=self._stamp)
        self._next_control = -np.inf
        self._say("planning", "", float(np.hypot(*(goal[:2] - self.pose()[:2]))), 0.0)

    def _on_odom(self, msg: Odometry) -> None:
        with self._control:
            self._control_step(msg)

    def _control_step(self, msg: Odometry) -> None:
        p = msg.pose.pose
        self.odom = np.array([p.position.x, p.position.y, _yaw(p.orientation)])
        self.velocity = (msg.twist.twist.linear.x, msg.twist.twist.angular.z)
        now = msg.header.stamp.to_sec()
        self._stamp = now
        if self.navigator is None:
            return
        if self._incoming is not None:
            incoming, self._incoming = self._incoming, None
            self._set_goal(incoming)
        if now < self._next_control:
            return
        self._next_control = now + self.config.dwa.period
        nav = self.navigator
        active = nav.status is Status.ACTIVE
        plans = len(nav.plan_times)
        v, w = nav.step(now, tuple(self.pose()), self.velocity)
        if active:
            self.cmd_pub.publish(
                Twist(linear=Vector3(x=v, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=w))
            )
        if self._goal is not None and self._goal.active:
            self._report_goal(now)
        if len(nav.plan_times) != plans and nav.path is not None:
            self._publish_plan(nav.path, now)
        status = nav.status.value + (f": {nav.message}" if nav.message else "")
        if status != self._last_status:
            self._last_status = status
            self.status_pub.publish(String(data=status))
        if active:
            self._report_status(now)
            res = nav.last_result
            if res is not None and now - self._local_at >= LOCAL_PLAN_PERIOD:
                self._local_at = now
                self._publish_local(res.trajectory, now)

    def _on_scan(self, msg: LaserScan) -> None:
        if self.amcl is None or self.navigator is None:
            return
        ranges = np.asarray(msg.ranges, dtype=float)
        angles = msg.angle_min + msg.angle_increment * np.arange(len(ranges))
        ranges = np.where((ranges >= msg.range_min) & (ranges < msg.range_max), ranges, np.inf)
        stamp = msg.header.stamp.to_sec()
        if self.amcl.update(tuple(self.odom), ranges, angles, tuple(self.laser_pose)):
            self.map_to_odom = self.amcl.map_to_odom(self.odom)
            self._publish_amcl(stamp)
        sensor = compose(self.pose(), self.laser_pose)
        ok = np.isfinite(ranges)
        a = sensor[2] + angles[ok]
        pts = np.column_stack(
            [sensor[0] + ranges[ok] * np.cos(a), sensor[1] + ranges[ok] * np.sin(a)]
        )
        self.navigator.observe((float(sensor[0]), float(sensor[1])), pts)
        if self.navigator.local_costmap is not None:
            self.local_pub.publish(costmap_message(self.navigator.local_costmap, stamp))

    # --- the navigate_to_pose action ----------------------------------------------------

    def _on_action_goal(self, handle: GoalHandle) -> None:
        with self._control:
            self._start_action_goal(handle)

    def _start_action_goal(self, handle: GoalHandle) -> None:
        self._preempt()
        self._goal = handle
        self._goal_start = -1.0  # taken from the next /odom stamp
        self._goal_recoveries = len(self.navigator.recoveries) if self.navigator else 0
        self._take(handle.goal.pose)

    def _on_action_cancel(self, handle: GoalHandle) -> None:
        with self._control:
            self._cancel_action_goal(handle)

    def _cancel_action_goal(self, handle: GoalHandle) -> None:
        if self.navigator is not None and self.navigator.status is Status.ACTIVE:
            self.navigator.cancel("canceled by the action client")
        self._incoming = None
        self.cmd_pub.publish(Twist())
        handle.canceled(nav2_msgs.NavigateToPoseResult(error_msg="canceled"))

    def _preempt(self) -> None:
        """End the running action goal because a new goal replaces it."""
        if self._goal is not None and self._goal.active:
            reason = "preempted by a new goal"
            self._goal.abort(
                nav2_msgs.NavigateToPoseResult(error_code=nav2_msgs.UNKNOWN, error_msg=reason),
                reason,
            )
        self._goal = None

    def _report_goal(self, now: float) -> None:
        """Feedback for the running action goal, or its result once the navigator ends."""
        nav, handle = self.navigator, self._goal
        if self._goal_start < 0.0:
            self._goal_start = now
        if nav.status is Status.SUCCEEDED:
            handle.succeed(nav2_msgs.NavigateToPoseResult(), nav.message)
            return
        if nav.status is not Status.ACTIVE:
            reason = nav.message or nav.status.value
            result = nav2_msgs.NavigateToPoseResult(error_code=nav2_msgs.UNKNOWN, error_msg=reason)
            handle.abort(result, reason)
            return
        pose = self.pose()
        left = self._distance_remaining(pose)
        speed = max(abs(self.velocity[0]), 0.05)
        handle.feedback(
            nav2_msgs.NavigateToPoseFeedback(
                current_pose=PoseStamped(
                    header=Header(stamp=Time.from_sec(now), frame_id="map"),
                    pose=Pose.planar(*pose),
                ),
                navigation_time=Duration.from_sec(max(now - self._goal_start, 0.0)),
                estimated_time_remaining=Duration.from_sec(left / speed),
                number_of_recoveries=len(nav.recoveries) - self._goal_recoveries,
                distance_remaining=left,
            )
        )

    def _distance_remaining(self, pose: np.ndarray) -> float:
        """Metres left along the plan from its point nearest the robot (straight to the
        goal while there is no plan)."""
        nav = self.navigator
        if nav.path is None or len(nav.path) < 2:
            return float(np.hypot(*(nav.goal[:2] - pose[:2])))
        path = np.asarray(nav.path, dtype=float)
        i = int(np.argmin(np.hypot(*(path - pose[:2]).T)))
        rest = np.vstack([pose[:2], path[i + 1 :] if i + 1 < len(path) else path[-1:]])
        return float(np.hypot(*np.diff(rest, axis=0).T).sum())

    # --- the status line ---------------------------------------------------------------

    def _report_status(self, now: float) -> None:
        """NavStatus for the running goal: when what it does changes, and every
        STATUS_PERIOD s while it runs (distance left, time so far)."""
        nav = self.navigator
        if self._goal_since is None:
            self._goal_since = now
        state, text = nav.phase()
        if len(nav.recoveries) > self._recoveries_said and state not in ("reached", "failed"):
            # a recovery that ends within the step (clearing the costmaps) is still said
            self._recoveries_said = len(nav.recoveries)
            state, text = "recovering", RECOVERY_WORDS[nav.recoveries[-1]]
        if (state, text) == self._said and now - self._said_at < STATUS_PERIOD:
            return
        self._said_at = now
        left = self._distance_remaining(self.pose()) if nav.goal is not None else -1.0
        if state == "reached":
            left = float(np.hypot(*(nav.goal[:2] - self.pose()[:2])))
        self._say(state, text, left, now - self._goal_since)

    def _say(self, state: str, text: str, left: float, elapsed: float) -> None:
        self._said = (state, text)
        goal = self._goal_msg or PoseStamped(header=Header(frame_id="map"))
        self.nav_status_pub.publish(
            NavStatus(
                state=state,
                text=text,
                distance_remaining=float(left),
                elapsed=float(max(elapsed, 0.0)),
                goal=goal,
            )
        )

    # --- outputs -----------------------------------------------------------------------

    def _publish_local(self, trajectory: np.ndarray, stamp: float) -> None:
        head = Header(stamp=Time.from_sec(stamp), frame_id="map")
        poses = [PoseStamped(header=head, pose=Pose.planar(*p)) for p in np.asarray(trajectory)]
        self.local_plan_pub.publish(Path(header=head, poses=poses))

    def pose(self) -> np.ndarray:
        """The robot's pose on the map: map -> odom (AMCL) composed with odometry."""
        return compose(self.map_to_odom, self.odom)

    def _publish_plan(self, path: np.ndarray, stamp: float) -> None:
        head = Header(stamp=Time.from_sec(stamp), frame_id="map")
        d = np.diff(path, axis=0)
        yaws = np.append(np.arctan2(d[:, 1], d[:, 0]), self.navigator.goal[2])
        self.plan_pub.publish(
            Path(
                header=head,
                poses=[
                    PoseStamped(header=head, pose=Pose.planar(x, y, t))
                    for (x, y), t in zip(path, yaws, strict=True)
                ],
            )
        )
        self.global_pub.publish(costmap_message(self.navigator.global_costmap, stamp))

    def _publish_amcl(self, stamp: float) -> None:
        est, cov = self.amcl.estimate()
        c = np.zeros((6, 6))
        c[:2, :2] = cov[:2, :2]
        c[5, 5] = cov[2, 2]
        c[:2, 5] = c[5, :2] = cov[:2, 2]
        head = Header(stamp=Time.from_sec(stamp), frame_id="map")
        self.pose_pub.publish(
            PoseWithCovarianceStamped(
                header=head,
                pose=PoseWithCovariance(pose=Pose.planar(*est), covariance=c.ravel().tolist()),
            )
        )
        self.cloud_pub.publish(
            PoseArray(header=head, poses=[Pose.planar(*p) for p in self.amcl.particles])
        )
