// One motion in the browser's physics: the tracker follows a joint reference while
// MuJoCo steps in real time, the hand's path is sampled against the planned one, and
// every touch between the robot (or the object) and an obstacle is recorded.

import { type JointReference, JointTracker } from "../physics/controller";
import type { Contact, PhysicsWorld } from "../physics/world";
import type { Vec3 } from "../types";
import type { PathSample } from "./plot";

/** How long the run goes on after the reference ends, for the arm to settle (s). */
const SETTLE = 0.5;
const SAMPLE_PERIOD = 0.01; // s
/** At most this much simulated time per drawn frame, so a slow frame cannot stall. */
const MAX_FRAME_TIME = 0.5; // s

export interface RunResult {
  samples: PathSample[];
  /** Where the hand ended, and how far that is from the goal (m). */
  finalPosition: Vec3;
  finalError: number;
  /** Root mean square and largest distance between the simulated and planned hand (m). */
  rmsGap: number;
  maxGap: number;
  /** Every distinct touch with an obstacle, and in how many steps one happened. */
  contacts: Contact[];
  contactSteps: number;
  /** Simulated and wall-clock seconds the run took. */
  simTime: number;
  wallTime: number;
}

export class MotionRun {
  private readonly samples: PathSample[] = [];
  private readonly contacts = new Map<string, Contact>();
  private contactSteps = 0;
  private cancelled = false;
  private nextSample = 0;

  constructor(
    private readonly world: PhysicsWorld,
    private readonly tracker: JointTracker,
    private readonly reference: JointReference,
    private readonly goal: Vec3,
    /** Called after each drawn frame's steps (update the view from the physics). */
    private readonly frame: (run: MotionRun) => void,
  ) {}

  get started(): number {
    return this.startTime;
  }

  private startTime = 0;

  /** Samples so far. */
  path(): PathSample[] {
    return this.samples;
  }

  /** Run to the end (resolves with the figures) unless cancelled (rejects). */
  play(): Promise<RunResult> {
    const world = this.world;
    this.startTime = world.time;
    this.tracker.follow(this.reference, this.startTime);
    const end = this.startTime + this.reference.duration + SETTLE;
    const wallStart = performance.now();
    let last = wallStart;
    return new Promise((resolve, reject) => {
      const tick = (now: number) => {
        if (this.cancelled) {
          reject(new Error("the motion was stopped"));
          return;
        }
        const until = Math.min(end, world.time + Math.min(MAX_FRAME_TIME, (now - last) / 1000));
        last = now;
        while (world.time < until - 1e-9) this.step();
        this.frame(this);
        if (world.time >= end - 1e-9) {
          resolve(this.result((performance.now() - wallStart) / 1000));
        } else {
          requestAnimationFrame(tick);
        }
      };
      this.sample();
      requestAnimationFrame(tick);
    });
  }

  cancel(): void {
    this.cancelled = true;
  }

  private step(): void {
    this.tracker.apply();
    this.world.step();
    const touching = this.world.obstacleContacts();
    if (touching.length) {
      this.contactSteps += 1;
      for (const c of touching) this.contacts.set(`${c.a}|${c.b}`, c);
    }
    if (this.world.time - this.startTime >= this.nextSample - 1e-9) this.sample();
  }

  private sample(): void {
    const t = this.world.time - this.startTime;
    const planned = this.world.tcpAt(this.tracker.target(this.world.time));
    this.samples.push({ t, planned, simulated: this.world.tcp() });
    this.nextSample = t + SAMPLE_PERIOD;
  }

  private result(wallTime: number): RunResult {
    const gaps = this.samples.map((s) => distance(s.planned, s.simulated));
    const finalPosition = this.world.tcp();
    return {
      samples: this.samples,
      finalPosition,
      finalError: distance(finalPosition, this.goal),
      rmsGap: Math.sqrt(gaps.reduce((a, g) => a + g * g, 0) / Math.max(1, gaps.length)),
      maxGap: Math.max(0, ...gaps),
      contacts: [...this.contacts.values()],
      contactSteps: this.contactSteps,
      simTime: this.world.time - this.startTime,
      wallTime,
    };
  }
}

function distance(a: Vec3, b: Vec3): number {
  return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}
