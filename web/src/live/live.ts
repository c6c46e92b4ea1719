// The live platform view (the RViz role): while the page shows the robot and room that
// the server simulates live, it follows the platform over rosbridge. The robot's pose
// comes from /tf, its joints from /joint_states; the 2D /scan is drawn as points, /map
// as a texture on the floor, /plan as a line. A click on the floor (after "Set
// navigation goal") publishes /move_base_simple/goal; arrow keys or WASD drive through
// /cmd_vel.

import {
  BufferAttribute,
  BufferGeometry,
  DataTexture,
  DoubleSide,
  Group,
  Line,
  LineBasicMaterial,
  Matrix4,
  Mesh,
  MeshBasicMaterial,
  NearestFilter,
  Plane,
  PlaneGeometry,
  Points,
  PointsMaterial,
  Quaternion,
  Raycaster,
  RGBAFormat,
  SRGBColorSpace,
  Vector2,
  Vector3,
} from "three";
import type { LiveInfo } from "../api";
import type {
  JointState,
  LaserScan,
  OccupancyGrid,
  Path,
  PoseStamped,
  Twist,
} from "../generated/msgs";
import type { RosConnection } from "../ros/connection";
import type { Robot } from "../robot";
import type { Viewer } from "../scene";
import "./live.css";
import { el } from "../ui/dom";
import { TfBuffer } from "./tf";
import { drive, DRIVE_KEYS, type DriveLimits } from "./keys";

export interface LiveState {
  /** True while the page shows the robot and world the server runs live. */
  active: boolean;
  /** Scans received while active, and the points drawn from the last one. */
  scans: number;
  scanPoints: number;
  /** The robot's base in the world: x, y (m), yaw (rad); null before the first /tf. */
  pose: [number, number, number] | null;
  map: { width: number; height: number; resolution: number } | null;
  /** Poses in the last /plan. */
  plan: number;
  /** The last navigation goal sent (world x, y), or null. */
  goal: [number, number] | null;
  /** The last /cmd_vel sent: linear x (m/s), angular z (rad/s). */
  drive: [number, number];
  error: string | null;
}

const SCAN_COLOR = 0xe0413a;
const PLAN_COLOR = 0x1f9d55;
const CMD_PERIOD_MS = 100;
const RENDER_PERIOD_MS = 100;
/** Joint states move sliders and wheels: ten updates a second are plenty. */
const JOINTS_PERIOD_MS = 100;
/** Heights above the floor (m) that keep the overlays from flickering into it. */
const MAP_Z = 0.004;
const PLAN_Z = 0.02;

export class LiveView {
  private info: LiveInfo | null = null;
  private robot: Robot | null = null;
  private active = false;
  private subscribed = false;
  private readonly tf = new TfBuffer();
  private readonly roots = new Map<string, Matrix4>();
  private readonly overlay = new Group();
  private readonly scanPoints = new Points(
    new BufferGeometry(),
    new PointsMaterial({ color: SCAN_COLOR, size: 4, sizeAttenuation: false }),
  );
  private readonly planLine = new Line(
    new BufferGeometry(),
    new LineBasicMaterial({ color: PLAN_COLOR, linewidth: 2 }),
  );
  private mapMesh: Mesh | null = null;
  private readonly counts = { scans: 0, scanPoints: 0, plan: 0 };
  private pose: [number, number, number] | null = null;
  private mapInfo: LiveState["map"] = null;
  private goal: [number, number] | null = null;
  private command: [number, number] = [0, 0];
  private readonly held = new Set<string>();
  private cmdTimer: number | undefined;
  private renderTimer: number | undefined;
  private lastJoints = -Infinity;
  private pickingGoal = false;
  /** The panel section: the app mounts it (Panel.mount). */
  readonly section: HTMLElement;
  private readonly statusLine = el("p", { class: "hint", id: "live-status" });
  private readonly goalButton = el(
    "button",
    { type: "button", id: "live-goal", class: "quiet" },
    "Set navigation goal",
  );

  constructor(
    private readonly viewer: Viewer,
    private readonly ros: RosConnection,
    private readonly setJoints: (values: Record<string, number>) => void,
  ) {
    this.overlay.name = "live-overlay";
    this.scanPoints.frustumCulled = false;
    this.planLine.frustumCulled = false;
    this.overlay.add(this.scanPoints, this.planLine);
    this.overlay.visible = false;
    viewer.scene.add(this.overlay);

    this.section = el(
      "section",
      { class: "live", id: "live-view", hidden: "" },
      el("h2", {}, "Live platform"),
      this.statusLine,
      el(
        "p",
        { class: "hint" },
        "Drive with the arrow keys or W A S D. Click the floor after pressing the button " +
          "to send a navigation goal.",
      ),
      this.goalButton,
    );
    this.goalButton.addEventListener("click", () => this.armGoal(!this.pickingGoal));
    this.listenForGoalClicks(viewer.renderer.domElement);
    window.addEventListener("keydown", (e) => this.key(e, true));
    window.addEventListener("keyup", (e) => this.key(e, false));
    window.addEventListener("blur", () => this.stopDriving());
  }

  /** Tell the view what the server runs live (null: nothing). */
  setInfo(info: LiveInfo | null): void {
    this.info = info;
  }

  /** The page now shows `robot` in `world`: follow the platform if it is the live one. */
  shown(robotName: string, worldName: string, robot: Robot | null): void {
    const info = this.info;
    const live = !!info && !!robot && info.robot === robotName && info.world === worldName;
    this.robot = live ? robot : null;
    this.active = live;
    this.overlay.visible = live;
    this.section.hidden = !live;
    if (!live || !info) {
      this.stopDriving();
      this.armGoal(false);
      return;
    }
    const origin = new Matrix4().compose(
      new Vector3(...info.origin.xyz),
      new Quaternion(...info.origin.quat),
      new Vector3(1, 1, 1),
    );
    this.roots.set("odom", origin);
    this.roots.set("map", origin);
    this.statusLine.textContent = info.error ?? "Following the simulated platform.";
    this.subscribe();
  }

  state(): LiveState {
    return {
      active: this.active,
      scans: this.counts.scans,
      scanPoints: this.counts.scanPoints,
      pose: this.pose,
      map: this.mapInfo,
      plan: this.counts.plan,
      goal: this.goal,
      drive: this.command,
      error: this.info?.error ?? null,
    };
  }

  private subscribe(): void {
    if (this.subscribed) return;
    this.subscribed = true;
    // The platform streams more than a page drawing with software WebGL can take in:
    // frames come as CBOR, and the server keeps only the newest scan, map and plan
    // waiting. /tf carries the simulator's joint and odometry transforms and SLAM's
    // map -> odom in separate messages, so a few of them may wait. (No rosbridge
    // throttle_rate: joint states are thinned out here instead.)
    const latest = { queueLength: 1, cbor: true };
    this.ros.subscribe("/tf_static", (m) => this.tf.add(m), { cbor: true });
    this.ros.subscribe(
      "/tf",
      (m) => {
        this.tf.add(m);
        if (this.active) this.placeRobot();
      },
      { queueLength: 20, cbor: true },
    );
    this.ros.subscribe("/joint_states", (m) => this.active && this.joints(m), latest);
    this.ros.subscribe("/scan", (m) => this.active && this.scan(m), latest);
    this.ros.subscribe("/map", (m) => this.active && this.map(m), latest);
    this.ros.subscribe("/plan", (m) => this.active && this.plan(m), latest);
  }

  private placeRobot(): void {
    const robot = this.robot;
    const holder = robot?.object.parent;
    if (!robot || !holder) return;
    const base = this.tf.inWorld(robot.root.name, this.roots);
    if (!base) return;
    const position = new Vector3();
    const rotation = new Quaternion();
    base.decompose(position, rotation, new Vector3());
    // The camera travels with the robot, so it stays in view while it drives.
    const moved = position.clone().sub(holder.position);
    this.viewer.camera.position.add(moved);
    this.viewer.controls.target.add(moved);
    holder.position.copy(position);
    holder.quaternion.copy(rotation);
    const forward = new Vector3(1, 0, 0).applyQuaternion(rotation);
    this.pose = [position.x, position.y, Math.atan2(forward.y, forward.x)];
    this.renderSoon();
  }

  private joints(m: JointState): void {
    const now = performance.now();
    if (now - this.lastJoints < JOINTS_PERIOD_MS) return;
    this.lastJoints = now;
    const known = new Set(this.robot?.joints.map((j) => j.name) ?? []);
    const values: Record<string, number> = {};
    m.name.forEach((name, i) => {
      if (known.has(name) && Number.isFinite(m.position[i])) values[name] = m.position[i];
    });
    if (Object.keys(values).length) this.setJoints(values);
  }

  private scan(m: LaserScan): void {
    const pose = this.tf.inWorld(m.header.frame_id, this.roots);
    this.counts.scans += 1;
    if (!pose) return;
    const xyz: number[] = [];
    const p = new Vector3();
    const ranges = m.ranges;
    for (let i = 0; i < ranges.length; i++) {
      const r = ranges[i];
      // rosbridge sends inf and nan as null in JSON
      if (r === null || !Number.isFinite(r) || r < m.range_min || r > m.range_max) continue;
      const a = m.angle_min + i * m.angle_increment;
      p.set(r * Math.cos(a), r * Math.sin(a), 0).applyMatrix4(pose);
      xyz.push(p.x, p.y, p.z);
    }
    const geometry = new BufferGeometry();
    geometry.setAttribute("position", new BufferAttribute(new Float32Array(xyz), 3));
    this.scanPoints.geometry.dispose();
    this.scanPoints.geometry = geometry;
    this.counts.scanPoints = xyz.length / 3;
    this.renderSoon();
  }

  private map(m: OccupancyGrid): void {
    const { width, height, resolution, origin } = m.info;
    if (!width || !height) return;
    const pixels = new Uint8Array(width * height * 4);
    const cells = m.data;
    for (let i = 0; i < width * height; i++) {
      const v = cells[i];
      if (v < 0) continue; // unknown: transparent
      const occupied = v >= 50;
      pixels[i * 4] = occupied ? 40 : 250;
      pixels[i * 4 + 1] = occupied ? 44 : 250;
      pixels[i * 4 + 2] = occupied ? 52 : 250;
      pixels[i * 4 + 3] = occupied ? 235 : 150;
    }
    const texture = new DataTexture(pixels, width, height, RGBAFormat);
    texture.magFilter = NearestFilter;
    texture.colorSpace = SRGBColorSpace;
    texture.needsUpdate = true;
    if (this.mapMesh) {
      this.overlay.remove(this.mapMesh);
      this.mapMesh.geometry.dispose();
      const old = this.mapMesh.material as MeshBasicMaterial;
      old.map?.dispose();
      old.dispose();
    }
    // The grid's cell (0, 0) is at its origin pose; rows run along +y.
    const plane = new PlaneGeometry(width * resolution, height * resolution);
    plane.translate((width * resolution) / 2, (height * resolution) / 2, 0);
    const mesh = new Mesh(
      plane,
      new MeshBasicMaterial({ map: texture, transparent: true, side: DoubleSide, depthWrite: false }),
    );
    mesh.name = "live-map";
    const frame = this.tf.inWorld(m.header.frame_id || "map", this.roots) ?? this.roots.get("map");
    const local = new Matrix4().compose(
      new Vector3(origin.position.x, origin.position.y, origin.position.z),
      new Quaternion(
        origin.orientation.x,
        origin.orientation.y,
        origin.orientation.z,
        origin.orientation.w,
      ),
      new Vector3(1, 1, 1),
    );
    mesh.matrixAutoUpdate = false;
    mesh.matrix.copy(frame ?? new Matrix4()).multiply(local);
    mesh.matrix.elements[14] = MAP_Z;
    mesh.renderOrder = -1;
    this.overlay.add(mesh);
    this.mapMesh = mesh;
    this.mapInfo = { width, height, resolution };
    this.renderSoon();
  }

  private plan(m: Path): void {
    const frame = this.tf.inWorld(m.header.frame_id || "map", this.roots);
    const xyz: number[] = [];
    const p = new Vector3();
    for (const pose of m.poses) {
      const q = pose.pose.position;
      p.set(q.x, q.y, 0);
      if (frame) p.applyMatrix4(frame);
      xyz.push(p.x, p.y, PLAN_Z);
    }
    const geometry = new BufferGeometry();
    geometry.setAttribute("position", new BufferAttribute(new Float32Array(xyz), 3));
    this.planLine.geometry.dispose();
    this.planLine.geometry = geometry;
    this.counts.plan = m.poses.length;
    this.renderSoon();
  }

  /** Redraw at most every RENDER_PERIOD_MS: the platform streams faster than a page
   * drawing with software WebGL can draw, and each frame would delay the next message. */
  private renderSoon(): void {
    if (this.renderTimer !== undefined) return;
    this.renderTimer = window.setTimeout(() => {
      this.renderTimer = undefined;
      this.viewer.requestRender();
    }, RENDER_PERIOD_MS);
  }

  // --- navigation goal -------------------------------------------------------------

  private armGoal(on: boolean): void {
    this.pickingGoal = on && this.active;
    this.goalButton.classList.toggle("armed", this.pickingGoal);
    this.goalButton.textContent = this.pickingGoal
      ? "Click the floor… (Esc cancels)"
      : "Set navigation goal";
    this.viewer.controls.enabled = !this.pickingGoal;
  }

  private listenForGoalClicks(canvas: HTMLElement): void {
    canvas.addEventListener("pointerdown", (e) => {
      if (!this.pickingGoal || e.button !== 0) return;
      const rect = canvas.getBoundingClientRect();
      const ndc = new Vector2(
        ((e.clientX - rect.left) / rect.width) * 2 - 1,
        -((e.clientY - rect.top) / rect.height) * 2 + 1,
      );
      const ray = new Raycaster();
      ray.setFromCamera(ndc, this.viewer.camera);
      const hit = ray.ray.intersectPlane(new Plane(new Vector3(0, 0, 1), 0), new Vector3());
      if (hit) this.sendGoal(hit.x, hit.y);
      this.armGoal(false);
    });
  }

  /** Publish a goal at world (x, y), facing away from the robot. */
  sendGoal(x: number, y: number): void {
    const origin = this.roots.get("map");
    if (!origin || !this.active) return;
    const inMap = new Vector3(x, y, 0).applyMatrix4(origin.clone().invert());
    const from = this.pose
      ? new Vector3(this.pose[0], this.pose[1], 0).applyMatrix4(origin.clone().invert())
      : new Vector3();
    const yaw = Math.atan2(inMap.y - from.y, inMap.x - from.x);
    const goal: PoseStamped = {
      header: { stamp: { sec: 0, nanosec: 0 }, frame_id: "map" },
      pose: {
        position: { x: inMap.x, y: inMap.y, z: 0 },
        orientation: { x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) },
      },
    };
    if (this.ros.publish("/move_base_simple/goal", goal)) this.goal = [x, y];
  }

  // --- keyboard driving --------------------------------------------------------------

  private key(e: KeyboardEvent, down: boolean): void {
    if (e.key === "Escape" && down) this.armGoal(false);
    if (!this.active || !DRIVE_KEYS.has(e.key.length === 1 ? e.key.toLowerCase() : e.key)) return;
    const target = e.target as HTMLElement | null;
    if (target && /^(INPUT|SELECT|TEXTAREA)$/.test(target.tagName) && target.getAttribute("type") !== "range") {
      return;
    }
    e.preventDefault();
    const key = e.key.length === 1 ? e.key.toLowerCase() : e.key;
    if (down) this.held.add(key);
    else this.held.delete(key);
    this.sendCommand();
    if (this.held.size && this.cmdTimer === undefined) {
      this.cmdTimer = window.setInterval(() => this.sendCommand(), CMD_PERIOD_MS);
    }
    if (!this.held.size) this.stopTimer();
  }

  private sendCommand(): void {
    const [v, w] = drive(this.held, this.limits());
    const twist: Twist = { linear: { x: v, y: 0, z: 0 }, angular: { x: 0, y: 0, z: w } };
    if (this.ros.publish("/cmd_vel", twist)) this.command = [v, w];
  }

  private stopDriving(): void {
    const moving = this.held.size > 0 || this.command[0] !== 0 || this.command[1] !== 0;
    this.held.clear();
    this.stopTimer();
    if (moving) this.sendCommand();
  }

  private stopTimer(): void {
    window.clearInterval(this.cmdTimer);
    this.cmdTimer = undefined;
  }

  private limits(): DriveLimits {
    const d = this.robot?.description.metadata?.drive ?? {};
    return { speed: d.max_speed ?? 0.5, yawRate: d.max_yaw_rate ?? 1.0 };
  }
}
