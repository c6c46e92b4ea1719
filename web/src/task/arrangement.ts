// The arrangement of a task, as the user sets it up: the robot's start posture, the
// obstacles (boxes over the furniture), the object to carry and the hand's goal. It is
// what Move Robot! sends to the planner and what a scene file holds.
//
// All positions are in the robot's base frame (m), z up, as in the PlanTask service.

import type { Box as BoxMsg, PlanTaskRequest } from "../generated/msgs";
import type { Quat, Vec3 } from "../types";

export interface TaskBox {
  id: string;
  /** Full edge lengths along the box's own x, y, z (m). */
  size: Vec3;
  position: Vec3;
  quaternion: Quat;
}

export interface Arrangement {
  robot: string;
  world: string;
  /** Driven joint values by name (rad or m): the start posture. */
  joints: Record<string, number>;
  obstacles: TaskBox[];
  /** The object to carry (object B), or null. */
  object: TaskBox | null;
  /** Where the hand should end up. */
  goal: Vec3;
}

export const SCENE_FORMAT = "robotrial-scene";
export const SCENE_VERSION = 1;
const IDENTITY: Quat = [0, 0, 0, 1];

/** The paper's obstacle C and object B sizes, a sensible start for a desk arm. */
export const DEFAULT_OBSTACLE_SIZE: Vec3 = [0.1, 0.1, 0.2];
export const DEFAULT_OBJECT_SIZE: Vec3 = [0.025, 0.025, 0.025];

/** A rotation about z by `yaw` (rad) as a quaternion. */
export function yawQuat(yaw: number): Quat {
  return [0, 0, Math.sin(yaw / 2), Math.cos(yaw / 2)];
}

/** The rotation about z of a quaternion (rad). */
export function quatYaw([x, y, z, w]: Quat): number {
  return Math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
}

/** The PlanTask request for an arrangement, starting from `joints`. */
export function planRequest(arrangement: Arrangement, jointNames: string[]): PlanTaskRequest {
  const now = Date.now();
  return {
    current_joints: {
      header: {
        stamp: { sec: Math.floor(now / 1000), nanosec: (now % 1000) * 1e6 },
        frame_id: "",
      },
      name: jointNames,
      position: jointNames.map((n) => arrangement.joints[n] ?? 0),
      velocity: [],
      effort: [],
    },
    obstacles: arrangement.obstacles.map(boxMessage),
    object: arrangement.object
      ? boxMessage(arrangement.object)
      : boxMessage({ id: "", size: [0, 0, 0], position: [0, 0, 0], quaternion: IDENTITY }),
    ee_goal: {
      position: { x: arrangement.goal[0], y: arrangement.goal[1], z: arrangement.goal[2] },
      orientation: { x: 0, y: 0, z: 0, w: 0 },
    },
    planner: "",
    time_limit: 0,
  };
}

function boxMessage(box: TaskBox): BoxMsg {
  const [x, y, z] = box.position;
  const [qx, qy, qz, qw] = box.quaternion;
  return {
    id: box.id,
    size: { x: box.size[0], y: box.size[1], z: box.size[2] },
    pose: { position: { x, y, z }, orientation: { x: qx, y: qy, z: qz, w: qw } },
  };
}

/** The arrangement as a scene file (JSON text). */
export function sceneFile(arrangement: Arrangement): string {
  return JSON.stringify({ format: SCENE_FORMAT, version: SCENE_VERSION, ...arrangement }, null, 2);
}

/** Read a scene file; errors name the field that is wrong. */
export function parseSceneFile(text: string): Arrangement {
  let raw: unknown;
  try {
    raw = JSON.parse(text);
  } catch (err) {
    throw new Error(`the scene file is not JSON: ${(err as Error).message}`);
  }
  const doc = record(raw, "the scene file");
  if (doc.format !== SCENE_FORMAT) {
    throw new Error(`not a robotrial scene file ("format" should be "${SCENE_FORMAT}")`);
  }
  if (doc.version !== SCENE_VERSION) {
    throw new Error(
      `scene file version ${String(doc.version)} is not supported ` +
        `(this page reads ${SCENE_VERSION})`,
    );
  }
  const joints = record(doc.joints, "joints");
  for (const [name, v] of Object.entries(joints)) finite(v, `joints.${name}`);
  if (!Array.isArray(doc.obstacles)) throw new Error('"obstacles" must be a list');
  return {
    robot: text_(doc.robot, "robot"),
    world: text_(doc.world, "world"),
    joints: joints as Record<string, number>,
    obstacles: doc.obstacles.map((b, i) => taskBox(b, `obstacles[${i}]`)),
    object: doc.object === null || doc.object === undefined ? null : taskBox(doc.object, "object"),
    goal: vec(doc.goal, 3, "goal") as Vec3,
  };
}

function taskBox(raw: unknown, where: string): TaskBox {
  const b = record(raw, where);
  const size = vec(b.size, 3, `${where}.size`) as Vec3;
  if (size.some((s) => s <= 0)) throw new Error(`${where}.size must be positive, got ${size}`);
  const q = vec(b.quaternion ?? IDENTITY, 4, `${where}.quaternion`);
  const norm = Math.hypot(...q);
  if (norm < 1e-9) throw new Error(`${where}.quaternion must not be all zeros`);
  return {
    id: text_(b.id, `${where}.id`),
    size,
    position: vec(b.position, 3, `${where}.position`) as Vec3,
    quaternion: q.map((v) => v / norm) as Quat,
  };
}

function record(v: unknown, where: string): Record<string, unknown> {
  if (!v || typeof v !== "object" || Array.isArray(v))
    throw new Error(`${where} must be an object`);
  return v as Record<string, unknown>;
}

function text_(v: unknown, where: string): string {
  if (typeof v !== "string") throw new Error(`"${where}" must be text`);
  return v;
}

function finite(v: unknown, where: string): number {
  if (typeof v !== "number" || !Number.isFinite(v)) throw new Error(`"${where}" must be a number`);
  return v;
}

function vec(v: unknown, n: number, where: string): number[] {
  if (!Array.isArray(v) || v.length !== n)
    throw new Error(`"${where}" must be a list of ${n} numbers`);
  return v.map((x, i) => finite(x, `${where}[${i}]`));
}
