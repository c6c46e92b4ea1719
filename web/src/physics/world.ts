// Physics in the browser: MuJoCo's official WebAssembly build (npm mujoco-js) runs the
// robot and its scene from the MJCF the server writes (robotrial.model.mjcf), with the
// user's obstacles and the object to carry added to it here.
//
// The module (11 MB) is fetched only when physics is first needed, so the page is
// ready before it arrives. Names follow the MJCF conventions (EXTENSION.md): bodies
// and joints as the links and joints, a site "tcp", actuators named as their joints.

import type { MainModule, MjData, MjModel } from "mujoco-js";
import { Matrix4, Quaternion, Vector3 } from "three";
import type { MjcfBundle } from "../api";
import type { Quat, Vec3 } from "../types";

/** A box in the robot's base frame: full edge lengths, centre and orientation. */
export interface BoxSpec {
  id: string;
  size: Vec3;
  position: Vec3;
  quaternion: Quat;
}

/** What to add to the server's scene: static obstacles, and the object to carry,
 * either resting free in the scene or held in the hand at a fixed pose in the tcp frame. */
export interface TaskBodies {
  obstacles: BoxSpec[];
  object: BoxSpec | null;
  /** The object's pose in the tcp frame when it is in the hand; null: it rests free. */
  heldAt: { position: Vec3; quaternion: Quat } | null;
}

/** A touch between two bodies during a run, by name ("link3", "obstacle C", "object"). */
export interface Contact {
  a: string;
  b: string;
}

export const OBSTACLE_PREFIX = "obstacle/user/";
export const OBJECT_NAME = "object/carried";
const OBJECT_MASS = 0.05; // kg
const DIR = "/robotrial";

let module: Promise<MainModule> | null = null;

/** MuJoCo (WebAssembly), loaded once on first use. */
export function mujoco(): Promise<MainModule> {
  module ??= import("mujoco-js").then(async ({ default: load }) => {
    const mj = await load();
    mj.FS.mkdir(DIR);
    mj.FS.mount(mj.MEMFS, { root: "." }, DIR);
    return mj;
  });
  return module;
}

/** A compiled MuJoCo model of the robot, its scene, the obstacles and the object, and
 * the state that moves. Positions it reports are in the robot's base frame. */
export class PhysicsWorld {
  readonly model: MjModel;
  readonly data: MjData;
  /** For kinematics of other joint values, without touching `data`. */
  private readonly scratch: MjData;
  private readonly tcpSite: number;
  private readonly rootBody: number;
  private readonly objectBody: number;
  private readonly obstacleGeoms = new Map<number, string>();
  private readonly robotBodies = new Set<number>();
  private readonly joints = new Map<string, { qpos: number; dof: number; actuator: number }>();

  private constructor(
    readonly mj: MainModule,
    xmlPath: string,
    rootLink: string,
  ) {
    this.model = mj.MjModel.loadFromXML(xmlPath);
    this.data = new mj.MjData(this.model);
    this.scratch = new mj.MjData(this.model);
    const m = this.model;
    const id = (type: number, name: string) => mj.mj_name2id(m, type, name);
    const T = mj.mjtObj;
    this.tcpSite = id(T.mjOBJ_SITE.value, "tcp");
    if (this.tcpSite < 0) throw new Error("the robot's MJCF has no site named tcp");
    this.rootBody = id(T.mjOBJ_BODY.value, rootLink);
    if (this.rootBody < 0) throw new Error(`the robot's MJCF has no body "${rootLink}"`);
    this.objectBody = id(T.mjOBJ_BODY.value, OBJECT_NAME);
    for (let j = 0; j < m.njnt; j++) {
      const name = mj.mj_id2name(m, T.mjOBJ_JOINT.value, j);
      if (!name || name === OBJECT_NAME) continue;
      this.joints.set(name, {
        qpos: m.jnt_qposadr[j],
        dof: m.jnt_dofadr[j],
        actuator: id(T.mjOBJ_ACTUATOR.value, name),
      });
    }
    const parents: ArrayLike<number> = m.body_parentid;
    for (let b = 1; b < m.nbody; b++) {
      let a = b;
      while (a > 0 && a !== this.rootBody) a = parents[a];
      if (a === this.rootBody && b !== this.objectBody) this.robotBodies.add(b);
    }
    for (let g = 0; g < m.ngeom; g++) {
      const name = mj.mj_id2name(m, T.mjOBJ_GEOM.value, g) ?? "";
      if (name.startsWith(OBSTACLE_PREFIX)) {
        this.obstacleGeoms.set(g, name.slice(OBSTACLE_PREFIX.length));
      }
    }
    mj.mj_forward(m, this.data);
  }

  /** Compile the server's MJCF with `bodies` added. `rootLink`: the robot's root link. */
  static async create(
    bundle: MjcfBundle,
    bodies: TaskBodies,
    rootLink: string,
  ): Promise<PhysicsWorld> {
    const mj = await mujoco();
    for (const [name, base64] of Object.entries(bundle.assets)) {
      mj.FS.writeFile(`${DIR}/${name}`, decodeBase64(base64));
    }
    const xmlPath = `${DIR}/${bundle.name || "scene"}.xml`;
    mj.FS.writeFile(xmlPath, withTaskBodies(bundle.xml, bodies, rootLink));
    return new PhysicsWorld(mj, xmlPath, rootLink);
  }

  get time(): number {
    return this.data.time;
  }

  get timestep(): number {
    return this.model.opt.timestep;
  }

  /** The joints MuJoCo knows by name (the robot's, without the object's free joint). */
  jointNames(): string[] {
    return [...this.joints.keys()];
  }

  /** Put joints at `values` at rest and recompute positions (no dynamics). */
  setJoints(values: Record<string, number>): void {
    const qpos: Float64Array = this.data.qpos;
    const qvel: Float64Array = this.data.qvel;
    for (const [name, v] of Object.entries(values)) {
      const j = this.joints.get(name);
      if (!j) continue;
      qpos[j.qpos] = v;
      qvel[j.dof] = 0;
    }
    this.mj.mj_forward(this.model, this.data);
  }

  /** Back to the model's initial state with joints at `values`, time 0, at rest. */
  reset(values: Record<string, number>): void {
    this.mj.mj_resetData(this.model, this.data);
    this.setJoints(values);
  }

  /** Joint values by name (rad or m). */
  jointValues(): Record<string, number> {
    const qpos: Float64Array = this.data.qpos;
    return Object.fromEntries([...this.joints].map(([n, j]) => [n, qpos[j.qpos]]));
  }

  /** (qpos index, dof index, actuator index or -1) of a joint, or undefined. */
  joint(name: string): { qpos: number; dof: number; actuator: number } | undefined {
    return this.joints.get(name);
  }

  step(): void {
    this.mj.mj_step(this.model, this.data);
  }

  /** The end effector (site tcp) in the robot's base frame. */
  tcp(): Vec3 {
    return this.inBase(this.data, this.data.site_xpos, 3 * this.tcpSite);
  }

  /** Where the end effector would be at joint values `values` (kinematics only). */
  tcpAt(values: Record<string, number>): Vec3 {
    const d = this.scratch;
    const qpos: Float64Array = d.qpos;
    qpos.set(this.data.qpos);
    for (const [name, v] of Object.entries(values)) {
      const j = this.joints.get(name);
      if (j) qpos[j.qpos] = v;
    }
    this.mj.mj_kinematics(this.model, d);
    return this.inBase(d, d.site_xpos, 3 * this.tcpSite);
  }

  /** The carried object's pose in the robot's base frame, or null without an object. */
  objectPose(): { position: Vec3; quaternion: Quat } | null {
    if (this.objectBody < 0) return null;
    const b = this.objectBody;
    const world = new Matrix4().compose(
      new Vector3(...(Array.from(this.data.xpos.subarray(3 * b, 3 * b + 3)) as Vec3)),
      wxyzToQuaternion(this.data.xquat, 4 * b),
      new Vector3(1, 1, 1),
    );
    const local = this.baseInverse(this.data).multiply(world);
    const p = new Vector3();
    const q = new Quaternion();
    local.decompose(p, q, new Vector3());
    return { position: [p.x, p.y, p.z], quaternion: [q.x, q.y, q.z, q.w] };
  }

  /** Touches, right now, between the robot (or the object) and a user obstacle. */
  obstacleContacts(): Contact[] {
    const n = this.data.ncon;
    if (n === 0 || this.obstacleGeoms.size === 0) return [];
    const out: Contact[] = [];
    const bodyOf: ArrayLike<number> = this.model.geom_bodyid;
    const contacts = this.data.contact;
    for (let i = 0; i < n; i++) {
      const c = contacts.get(i);
      if (!c) continue;
      const [g1, g2] = [c.geom1, c.geom2];
      c.delete();
      for (const [g, other] of [
        [g1, g2],
        [g2, g1],
      ]) {
        const obstacle = this.obstacleGeoms.get(g);
        const body = bodyOf[other];
        if (obstacle === undefined) continue;
        if (body === this.objectBody) out.push({ a: "object", b: `obstacle ${obstacle}` });
        else if (this.robotBodies.has(body)) {
          const link = this.mj.mj_id2name(this.model, this.mj.mjtObj.mjOBJ_BODY.value, body);
          out.push({ a: link ?? `body ${body}`, b: `obstacle ${obstacle}` });
        }
      }
    }
    contacts.delete();
    return out;
  }

  /** MuJoCo steps per second of wall time for this model, stepping a copy of the state
   * for about `seconds` (the real-time factor is this times the timestep). */
  measureSpeed(seconds = 1): { stepsPerSecond: number; realTimeFactor: number; steps: number } {
    const d = new this.mj.MjData(this.model, this.data);
    let steps = 0;
    const start = performance.now();
    const end = start + seconds * 1000;
    while (performance.now() < end) {
      for (let i = 0; i < 100; i++) this.mj.mj_step(this.model, d);
      steps += 100;
    }
    const elapsed = (performance.now() - start) / 1000;
    d.delete();
    const stepsPerSecond = steps / elapsed;
    return { stepsPerSecond, realTimeFactor: stepsPerSecond * this.timestep, steps };
  }

  dispose(): void {
    this.scratch.delete();
    this.data.delete();
    this.model.delete();
  }

  private inBase(d: MjData, xyz: Float64Array, at: number): Vec3 {
    const p = new Vector3(xyz[at], xyz[at + 1], xyz[at + 2]).applyMatrix4(this.baseInverse(d));
    return [p.x, p.y, p.z];
  }

  private baseInverse(d: MjData): Matrix4 {
    const b = this.rootBody;
    const xpos: Float64Array = d.xpos;
    return new Matrix4()
      .compose(
        new Vector3(xpos[3 * b], xpos[3 * b + 1], xpos[3 * b + 2]),
        wxyzToQuaternion(d.xquat, 4 * b),
        new Vector3(1, 1, 1),
      )
      .invert();
  }
}

/** The MJCF text with the user's obstacles (static boxes in the world body) and the
 * object (a free body, or a body fixed in the tcp's body while it is held). Their poses
 * are in the robot's base frame: where the body `rootLink` stands in the world. */
export function withTaskBodies(xml: string, bodies: TaskBodies, rootLink = ""): string {
  const doc = new DOMParser().parseFromString(xml, "application/xml");
  const error = doc.querySelector("parsererror");
  if (error) throw new Error(`the server's MJCF is not valid XML: ${error.textContent}`);
  const worldbody = doc.querySelector("worldbody");
  if (!worldbody) throw new Error("the server's MJCF has no <worldbody>");
  const root = [...worldbody.children].find(
    (e) => e.tagName === "body" && e.getAttribute("name") === rootLink,
  );
  const base = root ? poseMatrix(attr(root, "pos", "0 0 0"), attr(root, "quat", "1 0 0 0")) : null;
  /** `position` and `quaternion` (x, y, z, w) in the base frame as MJCF pos and quat. */
  const placed = (position: number[], quaternion: Quat): { pos: string; quat: string } => {
    if (!base) return { pos: position.join(" "), quat: wxyz(quaternion) };
    const p = new Vector3();
    const q = new Quaternion();
    base
      .clone()
      .multiply(
        new Matrix4().compose(
          new Vector3(...position),
          new Quaternion(...quaternion),
          new Vector3(1, 1, 1),
        ),
      )
      .decompose(p, q, new Vector3());
    return { pos: `${p.x} ${p.y} ${p.z}`, quat: `${q.w} ${q.x} ${q.y} ${q.z}` };
  };
  for (const box of bodies.obstacles) {
    worldbody.append(
      element(doc, "geom", {
        name: OBSTACLE_PREFIX + box.id,
        type: "box",
        size: halves(box.size),
        ...placed(box.position, box.quaternion),
        class: "world",
        rgba: "0.9 0.45 0.2 1",
      }),
    );
  }
  const object = bodies.object;
  if (object) {
    const geom = element(doc, "geom", {
      name: OBJECT_NAME,
      type: "box",
      size: halves(object.size),
      mass: String(OBJECT_MASS),
      rgba: "0.2 0.6 0.35 1",
      // Held: it touches the world (obstacles, table) but not the hand holding it.
      ...(bodies.heldAt ? { contype: "1", conaffinity: "0" } : { class: "world" }),
    });
    const body = element(doc, "body", { name: OBJECT_NAME });
    body.append(geom);
    if (bodies.heldAt) {
      const site = doc.querySelector('site[name="tcp"]');
      const hand = site?.parentElement;
      if (!site || !hand || hand.tagName !== "body") {
        throw new Error("the robot's MJCF has no site named tcp inside a body");
      }
      const inHand = poseMatrix(attr(site, "pos", "0 0 0"), attr(site, "quat", "1 0 0 0")).multiply(
        new Matrix4().compose(
          new Vector3(...bodies.heldAt.position),
          new Quaternion(...bodies.heldAt.quaternion),
          new Vector3(1, 1, 1),
        ),
      );
      const p = new Vector3();
      const q = new Quaternion();
      inHand.decompose(p, q, new Vector3());
      body.setAttribute("pos", `${p.x} ${p.y} ${p.z}`);
      body.setAttribute("quat", `${q.w} ${q.x} ${q.y} ${q.z}`);
      hand.append(body);
    } else {
      const at = placed(object.position, object.quaternion);
      body.setAttribute("pos", at.pos);
      body.setAttribute("quat", at.quat);
      body.prepend(element(doc, "freejoint", { name: OBJECT_NAME }));
      worldbody.append(body);
    }
  }
  return new XMLSerializer().serializeToString(doc);
}

function element(doc: XMLDocument, tag: string, attributes: Record<string, string>): Element {
  const e = doc.createElement(tag);
  for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, v);
  return e;
}

function attr(e: Element, name: string, fallback: string): number[] {
  return (e.getAttribute(name) ?? fallback).trim().split(/\s+/).map(Number);
}

function poseMatrix(pos: number[], quatWxyz: number[]): Matrix4 {
  const [w, x, y, z] = quatWxyz;
  return new Matrix4().compose(
    new Vector3(pos[0], pos[1], pos[2]),
    new Quaternion(x, y, z, w).normalize(),
    new Vector3(1, 1, 1),
  );
}

function halves(size: Vec3): string {
  return size.map((s) => s / 2).join(" ");
}

function wxyz([x, y, z, w]: Quat): string {
  return `${w} ${x} ${y} ${z}`;
}

function wxyzToQuaternion(q: Float64Array, at: number): Quaternion {
  return new Quaternion(q[at + 1], q[at + 2], q[at + 3], q[at]);
}

function decodeBase64(text: string): Uint8Array {
  const raw = atob(text);
  const out = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) out[i] = raw.charCodeAt(i);
  return out;
}
