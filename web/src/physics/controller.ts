// The browser's joint controller: it makes the simulated robot follow a joint
// reference (a trajectory_msgs/JointTrajectory from the planner) the way a real arm's
// servo loop would.
//
// Each joint's position servo (an MJCF <position> actuator: force = kp (u - q) - kv q')
// gets u = q_ref + (kv / kp) q'_ref, which turns it into a PD controller on both the
// position and the speed error, solved implicitly by MuJoCo, so it stays stable with
// stiff gains. Gravity and Coriolis forces are cancelled by adding MuJoCo's own bias
// force (qfrc_bias) to qfrc_applied: the servos only correct errors.

import type { JointTrajectory } from "../generated/msgs";
import type { PhysicsWorld } from "./world";

/** A joint trajectory that can be sampled at any time: cubic between points that give
 * speeds, linear between points that do not; held at the ends. */
export class JointReference {
  readonly names: string[];
  readonly times: number[];
  private readonly q: number[][];
  private readonly qd: number[][];

  constructor(msg: JointTrajectory) {
    if (msg.points.length === 0) throw new Error("the joint reference has no points");
    this.names = [...msg.joint_names];
    const n = this.names.length;
    this.times = msg.points.map((p) => p.time_from_start.sec + p.time_from_start.nanosec * 1e-9);
    msg.points.forEach((p, i) => {
      if (p.positions.length !== n) {
        throw new Error(`joint reference point ${i} has ${p.positions.length} positions, not ${n}`);
      }
      if (i > 0 && this.times[i] < this.times[i - 1]) {
        throw new Error(`joint reference point ${i} goes back in time`);
      }
    });
    this.q = msg.points.map((p) => [...p.positions]);
    this.qd = msg.points.map((p) => (p.velocities.length === n ? [...p.velocities] : []));
  }

  get duration(): number {
    return this.times[this.times.length - 1];
  }

  /** The final positions by joint name. */
  end(): Record<string, number> {
    return this.byName(this.q[this.q.length - 1]);
  }

  /** Positions and speeds at time `t` (s from the start). */
  sample(t: number): { q: number[]; qd: number[] } {
    const times = this.times;
    const last = times.length - 1;
    const zero = this.names.map(() => 0);
    if (t <= times[0]) return { q: [...this.q[0]], qd: zero };
    if (t >= times[last]) return { q: [...this.q[last]], qd: zero };
    let lo = 0;
    let hi = last;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (times[mid] <= t) lo = mid;
      else hi = mid;
    }
    const h = times[hi] - times[lo];
    if (h <= 0) return { q: [...this.q[hi]], qd: zero };
    const s = (t - times[lo]) / h;
    const [q0, q1, v0, v1] = [this.q[lo], this.q[hi], this.qd[lo], this.qd[hi]];
    if (v0.length === 0 || v1.length === 0) {
      return {
        q: q0.map((a, i) => a + s * (q1[i] - a)),
        qd: q0.map((a, i) => (q1[i] - a) / h),
      };
    }
    // Cubic Hermite: matches positions and speeds at both ends.
    const h00 = 2 * s ** 3 - 3 * s ** 2 + 1;
    const h10 = s ** 3 - 2 * s ** 2 + s;
    const h01 = -2 * s ** 3 + 3 * s ** 2;
    const h11 = s ** 3 - s ** 2;
    const d00 = (6 * s ** 2 - 6 * s) / h;
    const d10 = 3 * s ** 2 - 4 * s + 1;
    const d01 = (-6 * s ** 2 + 6 * s) / h;
    const d11 = 3 * s ** 2 - 2 * s;
    return {
      q: q0.map((a, i) => h00 * a + h10 * h * v0[i] + h01 * q1[i] + h11 * h * v1[i]),
      qd: q0.map((a, i) => d00 * a + d10 * v0[i] + d01 * q1[i] + d11 * v1[i]),
    };
  }

  byName(values: number[]): Record<string, number> {
    return Object.fromEntries(this.names.map((n, i) => [n, values[i]]));
  }
}

/** Drives every actuated joint of a PhysicsWorld towards targets: held values, or a
 * JointReference played from a start time. */
export class JointTracker {
  private held: Record<string, number> = {};
  private reference: JointReference | null = null;
  private startTime = 0;
  private readonly servos: Array<{
    name: string;
    qpos: number;
    dof: number;
    actuator: number;
    lead: number;
  }>;

  constructor(private readonly world: PhysicsWorld) {
    const m = world.model;
    const gain: Float64Array = m.actuator_gainprm;
    const bias: Float64Array = m.actuator_biasprm;
    // mjNGAIN = mjNBIAS = 10 parameters per actuator.
    this.servos = world
      .jointNames()
      .map((name) => ({ name, ...world.joint(name)! }))
      .filter((j) => j.actuator >= 0)
      .map((j) => {
        const kp = gain[10 * j.actuator];
        const kv = -bias[10 * j.actuator + 2];
        return { ...j, lead: kp > 0 && kv > 0 ? kv / kp : 0 };
      });
    this.hold(world.jointValues());
  }

  /** Keep joints at `values` (others keep their targets). */
  hold(values: Record<string, number>): void {
    this.held = { ...this.held, ...values };
  }

  /** Play `reference` from sim time `start`; afterwards hold its last point. */
  follow(reference: JointReference, start: number): void {
    this.reference = reference;
    this.startTime = start;
    this.hold(reference.end());
  }

  /** Where the reference wants the joints at sim time `t` (its end after it ends). */
  target(t: number): Record<string, number> {
    if (!this.reference) return { ...this.held };
    return { ...this.held, ...this.reference.byName(this.reference.sample(t - this.startTime).q) };
  }

  /** Set controls for the next step (call before every `world.step()`). */
  apply(): void {
    const d = this.world.data;
    const ctrl: Float64Array = d.ctrl;
    const applied: Float64Array = d.qfrc_applied;
    const bias: Float64Array = d.qfrc_bias;
    let q: Record<string, number> = this.held;
    let qd: Record<string, number> = {};
    if (this.reference) {
      const s = this.reference.sample(d.time - this.startTime);
      q = { ...this.held, ...this.reference.byName(s.q) };
      qd = this.reference.byName(s.qd);
    }
    for (const j of this.servos) {
      const target = q[j.name];
      if (target === undefined) continue;
      ctrl[j.actuator] = target + j.lead * (qd[j.name] ?? 0);
      applied[j.dof] = bias[j.dof];
    }
  }
}
