// window.robotrial: what scripts and tests may read from the page (docs/web.md).

import type { ArState } from "./ar/ar";
import type { LiveState } from "./live/live";
import type { ConnectionState } from "./ros/connection";
import type { TaskState } from "./task/session";
import type { Vec3 } from "./types";

export interface RobotrialState extends TaskState {
  robot: string;
  world: string;
  joints: { names: string[]; values: number[] };
  /** The end effector (tcp) in the robot's base frame (m); null before a robot loads. */
  endEffector: Vec3 | null;
  /** The link the end-effector read-out follows (the robot's tool link); "" before a
   * robot loads. */
  tool: string;
  /** True once the robot and world shown match `robot` and `world` and can be moved. */
  ready: boolean;
  /** Why the last load failed, or null. */
  error: string | null;
  /** The rosbridge link. */
  connection: ConnectionState;
  /** The AR session (ar/ar.ts): "unsupported" | "available" | "active" | "placed",
   * whether the reticle is on a surface, detected planes, and the robot's placement. */
  ar: ArState;
  /** The live platform view (live/live.ts): scans, pose, map, plan, goal, drive. */
  live: LiveState;
}

/** How fast MuJoCo steps the scene on screen in this browser. */
export interface PhysicsSpeed {
  stepsPerSecond: number;
  /** Simulated seconds per wall-clock second. */
  realTimeFactor: number;
  steps: number;
}

export interface RobotrialApi {
  /** A read-only copy of the page's state; later changes do not show in it. */
  state(): RobotrialState;
  /** Step a copy of the physics for about `seconds` and report the speed. */
  measurePhysics(seconds?: number): Promise<PhysicsSpeed>;
}

declare global {
  interface Window {
    robotrial: RobotrialApi;
  }
}

export function installWindowApi(
  source: () => RobotrialState,
  measurePhysics: (seconds?: number) => Promise<PhysicsSpeed>,
): void {
  const api: RobotrialApi = {
    state: () => deepFreeze(structuredClone(source())),
    measurePhysics,
  };
  Object.defineProperty(window, "robotrial", { value: Object.freeze(api), enumerable: true });
}

function deepFreeze<T>(value: T): T {
  if (value && typeof value === "object") {
    for (const v of Object.values(value)) deepFreeze(v);
    Object.freeze(value);
  }
  return value;
}
