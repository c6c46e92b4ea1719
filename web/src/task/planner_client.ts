// The planner over rosbridge: /robotrial/plan_task answers an arrangement with a
// trajectory (or with goal joints only), and /robotrial/joint_reference carries the
// motions the planner, or another ROS tool, sends. Turns either into a joint reference
// for the browser's physics.

import type { JointTrajectory, PlanTaskResponse } from "../generated/msgs";
import { JointReference } from "../physics/controller";
import type { RosConnection } from "../ros/connection";
import { type Arrangement, planRequest } from "./arrangement";
import { errorText } from "./wording";

/** How long to wait for /robotrial/joint_reference when the answer has no trajectory. */
const REFERENCE_WAIT_MS = 5000;
/** When to tell the user that planning takes longer than usual, and when to give up (ms). */
const PATIENCE_MS = 5000;
const PLAN_TIMEOUT_MS = 120_000;
/** Speed of the fallback move to the goal joints when no trajectory comes (rad/s). */
const FALLBACK_SPEED = 0.5;

export class PlannerClient {
  private lastReference: JointReference | null = null;
  private referenceWaiters: Array<(r: JointReference) => void> = [];

  /** `onReference(r)`: a motion arrived on /robotrial/joint_reference (after any plan
   * waiting for it has taken it). */
  constructor(
    private readonly connection: RosConnection,
    private readonly onReference: (reference: JointReference) => void,
  ) {
    connection.subscribe("/robotrial/joint_reference", (msg) => this.received(msg));
  }

  /** Ask the planner at `service` to move the hand as `arrangement` says; `names` are
   * the arm's driven joints in order. `slow()` is called once if the answer takes longer
   * than usual. Rejects when the planner cannot be reached or does not answer in time. */
  async plan(
    arrangement: Arrangement,
    names: string[],
    service: string,
    slow: () => void,
  ): Promise<PlanTaskResponse> {
    // A reference seen before this plan is not its motion.
    this.lastReference = null;
    const patience = window.setTimeout(slow, PATIENCE_MS);
    try {
      return await this.connection.call(
        "/robotrial/plan_task",
        planRequest(arrangement, names),
        PLAN_TIMEOUT_MS,
        service,
      );
    } finally {
      window.clearTimeout(patience);
    }
  }

  /** The motion of a successful answer: its trajectory; else the one a ROS system that
   * answers with goal joints only sends on the topic; else a plain move from `start`
   * to the goal joints. `names`: the arm's driven joints in order. */
  async reference(
    response: PlanTaskResponse,
    names: string[],
    start: Record<string, number>,
  ): Promise<JointReference> {
    if (response.trajectory.points.length > 0) return new JointReference(response.trajectory);
    const fromTopic = await new Promise<JointReference | null>((resolve) => {
      if (this.lastReference) return resolve(this.lastReference);
      const timer = setTimeout(() => resolve(null), REFERENCE_WAIT_MS);
      this.referenceWaiters.push((r) => {
        clearTimeout(timer);
        resolve(r);
      });
    });
    if (fromTopic) return fromTopic;
    const moved = names.slice(0, response.goal_joints.length);
    const from = moved.map((n) => start[n] ?? 0);
    const span = Math.max(...response.goal_joints.map((g, i) => Math.abs(g - from[i])), 1e-3);
    const trajectory: JointTrajectory = {
      header: { stamp: { sec: 0, nanosec: 0 }, frame_id: "" },
      joint_names: moved,
      points: [from, response.goal_joints].map((positions, i) => ({
        positions,
        velocities: moved.map(() => 0),
        accelerations: [],
        effort: [],
        time_from_start: { sec: i * Math.ceil(span / FALLBACK_SPEED), nanosec: 0 },
      })),
    };
    return new JointReference(trajectory);
  }

  private received(msg: JointTrajectory): void {
    let reference: JointReference;
    try {
      reference = new JointReference(msg);
    } catch (err) {
      console.warn("ignored a joint reference:", errorText(err));
      return;
    }
    this.lastReference = reference;
    const waiters = this.referenceWaiters;
    this.referenceWaiters = [];
    for (const w of waiters) w(reference);
    this.onReference(reference);
  }
}
