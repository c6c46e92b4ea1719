// The live platform view (the RViz role): while the page shows the robot and room that
// the server simulates live, it follows the platform over rosbridge. The robot's pose
// comes from /tf, its joints from /joint_states; the 2D /scan is drawn as points, /map
// as a layer on the floor (free, occupied and unknown cells in three shades, shown or
// hidden), the global /plan and the controller's /local_plan as lines, the base's
// footprint as its outline. "2D Goal Pose": a click on the floor sets the goal there,
// drawn as an arrow; dragging before letting go sets its heading (as in RViz); it goes
// out on /move_base_simple/goal. "2D Pose Estimate" does the same for /initialpose. The
// status line is the navigation node's NavStatus in words (live/words.ts): planning,
// driving, recovering, reached, failed, or a goal refused at once with the reason.
// Arrow keys or WASD drive through /cmd_vel.

import {
  ArrowHelper,
  BufferAttribute,
  BufferGeometry,
  DataTexture,
  DoubleSide,
  Group,
  Line,
  LineBasicMaterial,
  LineLoop,
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
  NavStatus,
  OccupancyGrid,
  Path,
  PolygonStamped,
  PoseStamped,
  PoseWithCovarianceStamped,
  Twist,
} from "../generated/msgs";
import type { RosConnection } from "../ros/connection";
import type { Robot } from "../robot";
import type { Viewer } from "../scene";
import "./live.css";
import { el } from "../ui/dom";
import { TfBuffer } from "./tf";
import { drive, DRIVE_KEYS, type DriveLimits } from "./keys";
import { statusLine } from "./words";

export interface LiveState {
  /** True while the page shows the robot and world the server runs live. */
  active: boolean;
  /** Scans received while active, and the points drawn from the last one. */
  scans: number;
  scanPoints: number;
  /** The robot's base in the world: x, y (m), yaw (rad); null before the first /tf. */
  pose: [number, number, number] | null;
  map: { width: number; height: number; resolution: number } | null;
  /** Cells of the last /map drawn as free, occupied and unknown. */
  mapCells: { free: number; occupied: number; unknown: number };
  /** Whether the map layer is shown. */
  mapShown: boolean;
  /** Poses in the last /plan and /local_plan. */
  plan: number;
  localPlan: number;
  /** Corners of the footprint outline drawn (0 before it arrives). */
  footprint: number;
  /** The last navigation goal sent (world x, y, yaw), or null. */
  goal: [number, number, number] | null;
  /** The last pose estimate sent (world x, y, yaw), or null. */
  poseEstimate: [number, number, number] | null;
  /** The navigation node's last status, and the status line it gave. */
  status: { state: string; text: string; distance: number; elapsed: number } | null;
  /** The states the navigator went through since the last goal was sent, in order. */
  statusHistory: string[];
  /** The status line said on entering each of those states. */
  statusLines: string[];
  statusLine: string;
  /** The last /cmd_vel sent: linear x (m/s), angular z (rad/s). */
  drive: [number, number];
  /** Where on the canvas (CSS pixels from its top left) the robot's floor point is, and
   * the floor 1 m east (+x) and north (+y) of it: for scripts that press on the floor. */
  screen: { robot: [number, number]; east: [number, number]; north: [number, number] } | null;
  error: string | null;
}

/** What a press on the floor sets: a navigation goal or a pose estimate. */
type Tool = "goal" | "pose";

const SCAN_COLOR = 0xe0413a;
const PLAN_COLOR = 0x1f9d55;
const LOCAL_COLOR = 0xf08c00;
const FOOTPRINT_COLOR = 0x1d4ed8;
const GOAL_COLOR = 0xc026d3;
const POSE_COLOR = 0x16a34a;
const DONE_COLOR = 0x8a94a3;
/** Map cells: free, occupied and unknown as RGBA (RViz's "map" scheme, on a floor). */
const FREE_RGBA = [250, 250, 250, 215];
const OCCUPIED_RGBA = [20, 24, 32, 255];
const UNKNOWN_RGBA = [96, 112, 130, 150];
/** A press that moves less than this (m) before it lets go keeps the default heading. */
const DRAG_MIN = 0.15;
/** RViz's 2D Pose Estimate covariance: 0.5 m and pi/12 rad standard deviations. */
const POSE_COVARIANCE = { xy: 0.25, yaw: (Math.PI / 12) ** 2 };
const CMD_PERIOD_MS = 100;
const RENDER_PERIOD_MS = 100;
/** Joint states move sliders and wheels: ten updates a second are plenty. */
const JOINTS_PERIOD_MS = 100;
/** Heights above the floor (m) that keep the overlays from flickering into it. */
const MAP_Z = 0.004;
const PLAN_Z = 0.02;
const LOCAL_Z = 0.025;
const FOOTPRINT_Z = 0.03;
const ARROW_Z = 0.05;

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
  private readonly localLine = new Line(
    new BufferGeometry(),
    new LineBasicMaterial({ color: LOCAL_COLOR, linewidth: 2 }),
  );
  private readonly footprintLine = new LineLoop(
    new BufferGeometry(),
    new LineBasicMaterial({ color: FOOTPRINT_COLOR, linewidth: 2 }),
  );
  private readonly goalArrow = new ArrowHelper(new Vector3(1, 0, 0), new Vector3(), 0.7, GOAL_COLOR, 0.25, 0.18);
  private readonly poseArrow = new ArrowHelper(new Vector3(1, 0, 0), new Vector3(), 0.7, POSE_COLOR, 0.25, 0.18);
  private mapMesh: Mesh | null = null;
  private readonly counts = { scans: 0, scanPoints: 0, plan: 0, localPlan: 0, footprint: 0 };
  private mapCells = { free: 0, occupied: 0, unknown: 0 };
  private mapShown = true;
  private pose: [number, number, number] | null = null;
  private mapInfo: LiveState["map"] = null;
  private goal: [number, number, number] | null = null;
  private poseEstimate: [number, number, number] | null = null;
  private status: NavStatus | null = null;
  private statusHistory: string[] = [];
  private statusLines: string[] = [];
  private command: [number, number] = [0, 0];
  private readonly held = new Set<string>();
  private cmdTimer: number | undefined;
  private renderTimer: number | undefined;
  private lastJoints = -Infinity;
  private tool: Tool | null = null;
  private drag: { tool: Tool; start: Vector3; yaw: number } | null = null;
  /** The panel section: the app mounts it (Panel.mount). */
  readonly section: HTMLElement;
  private readonly statusText = el("p", { class: "live-status", id: "live-status", role: "status", "aria-live": "polite" });
  private readonly goalButton = el(
    "button",
    { type: "button", id: "live-goal", class: "quiet", title: "Press on the floor; drag to set the heading" },
    "2D Goal Pose",
  );
  private readonly poseButton = el(
    "button",
    { type: "button", id: "live-pose", class: "quiet", title: "Press where the robot stands; drag along its heading" },
    "2D Pose Estimate",
  );
  /** The status line again, over the 3D view (RViz's status bar), while live. */
  private readonly hud = el("div", { class: "live-hud", id: "live-hud", role: "status", hidden: "" });
  private readonly topButton = el("button", { type: "button", id: "live-top", class: "quiet" }, "View from above");
  private readonly mapToggle = el("input", { type: "checkbox", id: "live-map", checked: "" });

  constructor(
    private readonly viewer: Viewer,
    private readonly ros: RosConnection,
    private readonly setJoints: (values: Record<string, number>) => void,
  ) {
    this.overlay.name = "live-overlay";
    for (const line of [this.scanPoints, this.planLine, this.localLine, this.footprintLine]) {
      line.frustumCulled = false;
    }
    this.footprintLine.matrixAutoUpdate = false;
    this.footprintLine.visible = false;
    this.goalArrow.visible = false;
    this.poseArrow.visible = false;
    this.overlay.add(this.scanPoints, this.planLine, this.localLine, this.footprintLine, this.goalArrow, this.poseArrow);
    this.overlay.visible = false;
    viewer.scene.add(this.overlay);

    this.section = el(
      "section",
      { class: "live", id: "live-view", hidden: "" },
      el("h2", {}, "Live platform"),
      this.statusText,
      el(
        "p",
        { class: "hint" },
        "2D Goal Pose: press on the floor where the robot should go, drag to set the way it " +
          "faces. 2D Pose Estimate: the same, where the robot stands. Drive with the arrow keys or W A S D.",
      ),
      el("div", { class: "live-tools" }, this.goalButton, this.poseButton, this.topButton),
      el("label", { class: "live-toggle" }, this.mapToggle, " Map (white free, black occupied, grey unknown)"),
    );
    this.say("Waiting for a goal.");
    viewer.renderer.domElement.parentElement?.append(this.hud);
    this.goalButton.addEventListener("click", () => this.arm(this.tool === "goal" ? null : "goal"));
    this.poseButton.addEventListener("click", () => this.arm(this.tool === "pose" ? null : "pose"));
    this.topButton.addEventListener("click", () => this.viewFromAbove());
    this.mapToggle.addEventListener("change", () => this.showMap(this.mapToggle.checked));
    this.listenForPoses(viewer.renderer.domElement);
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
    this.hud.hidden = !live;
    if (!live || !info) {
      this.stopDriving();
      this.arm(null);
      return;
    }
    const origin = new Matrix4().compose(
      new Vector3(...info.origin.xyz),
      new Quaternion(...info.origin.quat),
      new Vector3(1, 1, 1),
    );
    this.roots.set("odom", origin);
    this.roots.set("map", origin);
    if (info.error) this.say(info.error, "failed");
    else if (!this.status) this.say("Waiting for a goal.");
    this.subscribe();
  }

  state(): LiveState {
    return {
      active: this.active,
      scans: this.counts.scans,
      scanPoints: this.counts.scanPoints,
      pose: this.pose,
      map: this.mapInfo,
      mapCells: { ...this.mapCells },
      mapShown: this.mapShown,
      plan: this.counts.plan,
      localPlan: this.counts.localPlan,
      footprint: this.counts.footprint,
      goal: this.goal,
      poseEstimate: this.poseEstimate,
      status: this.status
        ? {
            state: this.status.state,
            text: this.status.text,
            distance: this.status.distance_remaining,
            elapsed: this.status.elapsed,
          }
        : null,
      statusHistory: [...this.statusHistory],
      statusLines: [...this.statusLines],
      statusLine: this.statusText.textContent ?? "",
      drive: this.command,
      screen: this.screen(),
      error: this.info?.error ?? null,
    };
  }

  private screen(): LiveState["screen"] {
    if (!this.pose) return null;
    const canvas = this.viewer.renderer.domElement;
    const [x, y] = this.pose;
    const at = (px: number, py: number): [number, number] => {
      const p = new Vector3(px, py, 0).project(this.viewer.camera);
      return [((p.x + 1) / 2) * canvas.clientWidth, ((1 - p.y) / 2) * canvas.clientHeight];
    };
    return { robot: at(x, y), east: at(x + 1, y), north: at(x, y + 1) };
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
    this.ros.subscribe("/local_plan", (m) => this.active && this.localPlan(m), latest);
    this.ros.subscribe("/move_base/local_costmap/footprint", (m) => this.footprint(m), latest);
    this.ros.subscribe("/robotrial/nav_status", (m) => this.navStatus(m), latest);
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
    this.footprintLine.matrix.copy(base);
    this.footprintLine.matrix.elements[14] = FOOTPRINT_Z;
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
    const count = { free: 0, occupied: 0, unknown: 0 };
    for (let i = 0; i < width * height; i++) {
      const v = cells[i];
      const kind = v < 0 ? "unknown" : v >= 50 ? "occupied" : "free";
      count[kind] += 1;
      pixels.set(kind === "unknown" ? UNKNOWN_RGBA : kind === "occupied" ? OCCUPIED_RGBA : FREE_RGBA, i * 4);
    }
    this.mapCells = count;
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
    mesh.visible = this.mapShown;
    this.overlay.add(mesh);
    this.mapMesh = mesh;
    this.mapInfo = { width, height, resolution };
    this.renderSoon();
  }

  private plan(m: Path): void {
    this.counts.plan = this.drawPath(this.planLine, m, PLAN_Z);
  }

  private localPlan(m: Path): void {
    this.counts.localPlan = this.drawPath(this.localLine, m, LOCAL_Z);
  }

  /** A path in its frame as a line `z` above the floor; returns its poses. */
  private drawPath(line: Line, m: Path, z: number): number {
    const frame = this.tf.inWorld(m.header.frame_id || "map", this.roots);
    const xyz: number[] = [];
    const p = new Vector3();
    for (const pose of m.poses) {
      const q = pose.pose.position;
      p.set(q.x, q.y, 0);
      if (frame) p.applyMatrix4(frame);
      xyz.push(p.x, p.y, z);
    }
    const geometry = new BufferGeometry();
    geometry.setAttribute("position", new BufferAttribute(new Float32Array(xyz), 3));
    line.geometry.dispose();
    line.geometry = geometry;
    this.renderSoon();
    return m.poses.length;
  }

  /** The base's rectangle (in its own frame): an outline that moves with the robot. */
  private footprint(m: PolygonStamped): void {
    const xyz = m.polygon.points.flatMap((q) => [q.x, q.y, 0]);
    const geometry = new BufferGeometry();
    geometry.setAttribute("position", new BufferAttribute(new Float32Array(xyz), 3));
    this.footprintLine.geometry.dispose();
    this.footprintLine.geometry = geometry;
    this.footprintLine.visible = xyz.length > 0;
    this.counts.footprint = m.polygon.points.length;
    this.renderSoon();
  }

  /** Say `text` in the panel's status line and over the view; `state` colours it. */
  private say(text: string, state = ""): void {
    for (const node of [this.statusText, this.hud]) {
      node.textContent = text;
      node.dataset.state = state;
    }
  }

  private navStatus(m: NavStatus): void {
    this.status = m;
    const line = statusLine(m);
    if (this.statusHistory[this.statusHistory.length - 1] !== m.state) {
      this.statusHistory.push(m.state);
      this.statusLines.push(line);
    }
    this.say(line, m.state);
    const done = m.state === "reached" || m.state === "failed" || m.state === "refused";
    this.goalArrow.setColor(done ? DONE_COLOR : GOAL_COLOR);
    if (m.state === "refused" || m.state === "failed") this.localLine.geometry.setDrawRange(0, 0);
    this.renderSoon();
  }

  private showMap(on: boolean): void {
    this.mapShown = on;
    if (this.mapMesh) this.mapMesh.visible = on;
    this.renderSoon();
  }

  /** Look straight down on the robot (RViz's top-down view), the room in sight. */
  private viewFromAbove(): void {
    const [x, y] = this.pose ?? [0, 0];
    const height = this.mapInfo ? Math.max(this.mapInfo.width, this.mapInfo.height) * this.mapInfo.resolution : 10;
    this.viewer.controls.target.set(x, y, 0);
    this.viewer.camera.position.set(x, y - 0.01, Math.min(Math.max(height, 6), 25));
    this.viewer.controls.update();
    this.viewer.requestRender();
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

  // --- 2D Goal Pose and 2D Pose Estimate -------------------------------------------

  private arm(tool: Tool | null): void {
    this.tool = this.active ? tool : null;
    this.drag = null;
    this.goalButton.classList.toggle("armed", this.tool === "goal");
    this.poseButton.classList.toggle("armed", this.tool === "pose");
    this.goalButton.textContent = this.tool === "goal" ? "Press on the floor… (Esc cancels)" : "2D Goal Pose";
    this.poseButton.textContent = this.tool === "pose" ? "Press where it stands… (Esc cancels)" : "2D Pose Estimate";
    this.viewer.controls.enabled = this.tool === null;
    if (this.tool === null) this.poseArrow.visible = false;
  }

  /** Where a pointer event meets the floor (world), or null. */
  private floorPoint(e: PointerEvent, canvas: HTMLElement): Vector3 | null {
    const rect = canvas.getBoundingClientRect();
    const ndc = new Vector2(
      ((e.clientX - rect.left) / rect.width) * 2 - 1,
      -((e.clientY - rect.top) / rect.height) * 2 + 1,
    );
    const ray = new Raycaster();
    ray.setFromCamera(ndc, this.viewer.camera);
    return ray.ray.intersectPlane(new Plane(new Vector3(0, 0, 1), 0), new Vector3());
  }

  private listenForPoses(canvas: HTMLElement): void {
    canvas.addEventListener("pointerdown", (e) => {
      if (!this.tool || e.button !== 0) return;
      const hit = this.floorPoint(e, canvas);
      if (!hit) return;
      // a goal faces away from the robot, a pose estimate keeps the robot's heading,
      // unless a drag says otherwise
      const from = this.pose ?? [hit.x - 1, hit.y, 0];
      const yaw = this.tool === "goal" ? Math.atan2(hit.y - from[1], hit.x - from[0]) : (this.pose?.[2] ?? 0);
      this.drag = { tool: this.tool, start: hit, yaw };
      canvas.setPointerCapture?.(e.pointerId);
      this.placeArrow(this.drag.tool === "goal" ? this.goalArrow : this.poseArrow, hit, yaw);
      e.preventDefault();
    });
    canvas.addEventListener("pointermove", (e) => {
      const drag = this.drag;
      if (!drag) return;
      const p = this.floorPoint(e, canvas);
      if (!p || p.distanceTo(drag.start) < DRAG_MIN) return;
      drag.yaw = Math.atan2(p.y - drag.start.y, p.x - drag.start.x);
      this.placeArrow(drag.tool === "goal" ? this.goalArrow : this.poseArrow, drag.start, drag.yaw);
    });
    const release = (e: PointerEvent) => {
      const drag = this.drag;
      if (!drag) return;
      this.drag = null;
      canvas.releasePointerCapture?.(e.pointerId);
      if (drag.tool === "goal") this.sendGoal(drag.start.x, drag.start.y, drag.yaw);
      else this.sendPoseEstimate(drag.start.x, drag.start.y, drag.yaw);
      this.arm(null);
    };
    canvas.addEventListener("pointerup", release);
    canvas.addEventListener("pointercancel", () => {
      this.drag = null;
      this.arm(null);
    });
  }

  private placeArrow(arrow: ArrowHelper, at: Vector3, yaw: number): void {
    arrow.position.set(at.x, at.y, ARROW_Z);
    arrow.setDirection(new Vector3(Math.cos(yaw), Math.sin(yaw), 0));
    arrow.visible = true;
    this.renderSoon();
  }

  /** A world pose (x, y, yaw) in the map frame: (x, y, yaw) there. */
  private toMap(x: number, y: number, yaw: number): [number, number, number] | null {
    const origin = this.roots.get("map");
    if (!origin) return null;
    const inverse = origin.clone().invert();
    const p = new Vector3(x, y, 0).applyMatrix4(inverse);
    const ahead = new Vector3(x + Math.cos(yaw), y + Math.sin(yaw), 0).applyMatrix4(inverse);
    return [p.x, p.y, Math.atan2(ahead.y - p.y, ahead.x - p.x)];
  }

  /** Publish a navigation goal at world (x, y) facing `yaw` (default: away from the
   * robot), and draw it. */
  sendGoal(x: number, y: number, yaw?: number): void {
    if (!this.active) return;
    const from = this.pose ?? [x - 1, y, 0];
    const heading = yaw ?? Math.atan2(y - from[1], x - from[0]);
    const inMap = this.toMap(x, y, heading);
    if (!inMap) return;
    const goal: PoseStamped = {
      header: { stamp: { sec: 0, nanosec: 0 }, frame_id: "map" },
      pose: {
        position: { x: inMap[0], y: inMap[1], z: 0 },
        orientation: { x: 0, y: 0, z: Math.sin(inMap[2] / 2), w: Math.cos(inMap[2] / 2) },
      },
    };
    if (this.ros.publish("/move_base_simple/goal", goal)) {
      this.goal = [x, y, heading];
      this.status = null; // the last goal's answer is not this one's
      this.statusHistory = [];
      this.statusLines = [];
      this.placeArrow(this.goalArrow, new Vector3(x, y, 0), heading);
      this.goalArrow.setColor(GOAL_COLOR);
      this.say("Goal sent…", "planning");
    }
  }

  /** Publish a pose estimate (RViz's 2D Pose Estimate) at world (x, y) facing `yaw`. */
  sendPoseEstimate(x: number, y: number, yaw: number): void {
    if (!this.active) return;
    const inMap = this.toMap(x, y, yaw);
    if (!inMap) return;
    const covariance = new Array<number>(36).fill(0);
    covariance[0] = covariance[7] = POSE_COVARIANCE.xy;
    covariance[35] = POSE_COVARIANCE.yaw;
    const msg: PoseWithCovarianceStamped = {
      header: { stamp: { sec: 0, nanosec: 0 }, frame_id: "map" },
      pose: {
        pose: {
          position: { x: inMap[0], y: inMap[1], z: 0 },
          orientation: { x: 0, y: 0, z: Math.sin(inMap[2] / 2), w: Math.cos(inMap[2] / 2) },
        },
        covariance,
      },
    };
    if (this.ros.publish("/initialpose", msg)) {
      this.poseEstimate = [x, y, yaw];
      this.say("Pose estimate sent: localization starts over from there.");
      window.setTimeout(() => {
        this.poseArrow.visible = false;
        this.renderSoon();
      }, 1500);
    }
  }

  // --- keyboard driving --------------------------------------------------------------

  private key(e: KeyboardEvent, down: boolean): void {
    if (e.key === "Escape" && down) this.arm(null);
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
