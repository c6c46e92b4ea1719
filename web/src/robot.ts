// A robot loaded from RDTF (glTF binary with the RDTF_robot extension, docs/rdtf.md):
// its link nodes, its joints, and forward kinematics done the RDTF way: a joint's child
// node gets the local transform origin * motion(q).

import { Matrix4, Object3D, Quaternion, Vector3 } from "three";
import { GLTFLoader, type GLTF } from "three/examples/jsm/loaders/GLTFLoader.js";
import type { Quat, Vec3 } from "./types";

/** RDTF stores non-finite floats as the strings "inf", "-inf" and "nan". */
type Num = number | string;

export type JointType = "revolute" | "continuous" | "prismatic" | "fixed" | "floating" | "planar";

export interface RdtfJoint {
  name: string;
  type: JointType;
  parent: string;
  child: string;
  axis: Vec3;
  origin: { xyz: Vec3; quat: Quat };
  limit: { lower: Num; upper: Num; effort: Num; velocity: Num } | null;
  mimic: { joint: string; multiplier: Num; offset: Num } | null;
}

export interface RdtfRobot {
  name: string;
  tcp: string;
  joints: RdtfJoint[];
  metadata?: {
    groups?: Record<string, string[]>;
    gripper?: { joints: string[] };
    drive?: Record<string, number>;
  };
}

/** A joint the user (or a controller) drives: one value, within [lower, upper]. */
export interface ActuatedJoint {
  name: string;
  type: "revolute" | "continuous" | "prismatic";
  lower: number;
  upper: number;
  /** "arm", "gripper", another group named in the robot's metadata, or "other". */
  group: string;
}

/** How one joint moves its child node: origin, axis, and the joint whose value it takes. */
interface JointMotion {
  joint: RdtfJoint;
  node: Object3D;
  origin: Matrix4;
  axis: Vector3;
  /** The actuated joint this one follows, value = multiplier * q + offset. */
  source: string;
  multiplier: number;
  offset: number;
}

const MOVING = new Set(["revolute", "continuous", "prismatic"]);

export class Robot {
  /** Everything the file holds; add this to a scene. */
  readonly object: Object3D;
  /** The root link's node: the robot's base frame. */
  readonly root: Object3D;
  readonly description: RdtfRobot;
  readonly joints: ActuatedJoint[];
  readonly tcp: Object3D;
  private readonly values = new Map<string, number>();
  private readonly motions: JointMotion[] = [];

  constructor(gltf: GLTF, source: string) {
    const ext = (gltf.parser.json.extensions ?? {}).RDTF_robot as RdtfRobot | undefined;
    if (!ext) throw new Error(`${source}: not an RDTF file (no RDTF_robot extension)`);
    this.description = ext;
    this.object = gltf.scene;
    const nodes = linkNodes(gltf);
    const find = (link: string, what: string): Object3D => {
      const node = nodes.get(link);
      if (!node) throw new Error(`${source}: ${what} names link "${link}", which has no node`);
      return node;
    };
    const rootName = rootLink(ext);
    this.root = rootName
      ? find(rootName, "the kinematic tree")
      : (gltf.scene.children[0] ?? gltf.scene);
    this.tcp = ext.tcp ? find(ext.tcp, "tcp") : this.root;

    const groups = jointGroups(ext);
    this.joints = ext.joints
      .filter((j) => MOVING.has(j.type) && !j.mimic)
      .map((j) => {
        const [lower, upper] = sliderRange(j);
        const type = j.type as ActuatedJoint["type"];
        return { name: j.name, type, lower, upper, group: groups.get(j.name) ?? "other" };
      });
    for (const j of this.joints) this.values.set(j.name, clamp(0, j.lower, j.upper));

    const actuated = new Set(this.joints.map((j) => j.name));
    for (const joint of ext.joints) {
      if (!MOVING.has(joint.type)) continue;
      const leader = joint.mimic ? joint.mimic.joint : joint.name;
      if (!actuated.has(leader)) {
        throw new Error(`${source}: joint "${joint.name}" mimics "${leader}", which is not driven`);
      }
      const [x, y, z] = joint.origin.xyz;
      const [qx, qy, qz, qw] = joint.origin.quat;
      this.motions.push({
        joint,
        node: find(joint.child, `joint "${joint.name}"`),
        origin: new Matrix4().compose(
          new Vector3(x, y, z),
          new Quaternion(qx, qy, qz, qw),
          new Vector3(1, 1, 1),
        ),
        axis: new Vector3(...joint.axis).normalize(),
        source: leader,
        multiplier: joint.mimic ? num(joint.mimic.multiplier) : 1,
        offset: joint.mimic ? num(joint.mimic.offset) : 0,
      });
    }
    this.apply();
  }

  /** Joint values in the order of `joints` (rad or m). */
  jointValues(): number[] {
    return this.joints.map((j) => this.values.get(j.name) ?? 0);
  }

  /** Joint values by joint name (rad or m). */
  valuesByName(): Record<string, number> {
    return Object.fromEntries(this.values);
  }

  /** Set driven joints by name (clamped to their limits) and move the nodes. */
  setJoints(values: Record<string, number>): void {
    for (const [name, v] of Object.entries(values)) {
      const j = this.joints.find((k) => k.name === name);
      if (!j) throw new Error(`robot "${this.description.name}" has no driven joint "${name}"`);
      this.values.set(name, clamp(v, j.lower, j.upper));
    }
    this.apply();
  }

  /** The end effector's (tcp node's) position in the robot's base (root link) frame. */
  endEffector(): Vec3 {
    this.root.updateWorldMatrix(true, true);
    const p = this.tcp.getWorldPosition(new Vector3());
    this.root.worldToLocal(p);
    return [p.x, p.y, p.z];
  }

  private apply(): void {
    const motion = new Matrix4();
    const rotation = new Quaternion();
    for (const m of this.motions) {
      const q = m.multiplier * (this.values.get(m.source) ?? 0) + m.offset;
      if (m.joint.type === "prismatic") {
        motion.makeTranslation(m.axis.x * q, m.axis.y * q, m.axis.z * q);
      } else {
        motion.makeRotationFromQuaternion(rotation.setFromAxisAngle(m.axis, q));
      }
      m.node.matrix.multiplyMatrices(m.origin, motion);
      m.node.matrix.decompose(m.node.position, m.node.quaternion, m.node.scale);
    }
    this.root.updateMatrixWorld(true);
  }
}

/** Fetch and parse an RDTF file. */
export async function loadRobot(url: string): Promise<Robot> {
  const gltf = await new GLTFLoader().loadAsync(url);
  return new Robot(gltf, url);
}

/** glTF node name -> three.js object, by node index (three.js rewrites some names). */
function linkNodes(gltf: GLTF): Map<string, Object3D> {
  const nodes: Array<{ name?: string }> = gltf.parser.json.nodes ?? [];
  const names = nodes.map((n) => n.name ?? "");
  const out = new Map<string, Object3D>();
  for (const [object, refs] of gltf.parser.associations) {
    if (refs.nodes !== undefined && object instanceof Object3D && !out.has(names[refs.nodes])) {
      out.set(names[refs.nodes], object);
    }
  }
  return out;
}

function rootLink(robot: RdtfRobot): string {
  const children = new Set(robot.joints.map((j) => j.child));
  const parents = robot.joints.map((j) => j.parent).filter((p) => !children.has(p));
  return parents[0] ?? "";
}

/** Joint name -> group: named groups from the metadata first, then the gripper. */
function jointGroups(robot: RdtfRobot): Map<string, string> {
  const out = new Map<string, string>();
  for (const [group, joints] of Object.entries(robot.metadata?.groups ?? {})) {
    for (const j of joints) if (!out.has(j)) out.set(j, group);
  }
  for (const j of robot.metadata?.gripper?.joints ?? []) if (!out.has(j)) out.set(j, "gripper");
  return out;
}

/** The range a slider offers: the joint's limits, or one turn (1 m) where there are none. */
function sliderRange(joint: RdtfJoint): [number, number] {
  const free: [number, number] = joint.type === "prismatic" ? [-1, 1] : [-Math.PI, Math.PI];
  if (joint.type === "continuous" || !joint.limit) return free;
  const lower = num(joint.limit.lower);
  const upper = num(joint.limit.upper);
  return [Number.isFinite(lower) ? lower : free[0], Number.isFinite(upper) ? upper : free[1]];
}

function num(v: Num): number {
  return typeof v === "number" ? v : Number(v.replace("inf", "Infinity"));
}

function clamp(v: number, lo: number, hi: number): number {
  return Math.min(hi, Math.max(lo, v));
}
