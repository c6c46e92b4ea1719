// The g2rViewer workflow for an arm, as a state machine over the phases editing, set,
// planning, moving and done: arrange obstacles, the object and the goal; Set Robot
// fixes the start; Move Robot! asks the planner (planner_client.ts) and plays its
// answer in the browser's physics; Reset Robot goes back to editing. What it says is
// worded in wording.ts; the scene and path files are written by exports.ts.

import { Matrix4, Quaternion, Vector3 } from "three";
import { fetchMjcf, type MjcfBundle } from "../api";
import type { PlanTaskResponse } from "../generated/msgs";
import { type JointReference, JointTracker } from "../physics/controller";
import { mujoco, PhysicsWorld } from "../physics/world";
import type { Robot } from "../robot";
import type { RosConnection } from "../ros/connection";
import type { Viewer } from "../scene";
import type { Quat, Vec3 } from "../types";
import {
  type Arrangement,
  DEFAULT_OBJECT_SIZE,
  DEFAULT_OBSTACLE_SIZE,
  parseSceneFile,
  type TaskBox,
} from "./arrangement";
import { TaskEditor } from "./editor";
import { savePath, saveSceneFile } from "./exports";
import type { MessageKind, Phase, TaskPanel } from "./panel";
import { PlannerClient } from "./planner_client";
import { chartImage, pathChart } from "./plot";
import { MotionRun, type RunResult } from "./run";
import * as wording from "./wording";

/** An object this close to the hand (m, from the tcp to the box) is in the hand: the
 * planner's rule (robotrial.planning.task.HOLD_DISTANCE). */
const HOLD_DISTANCE = 0.05;

export interface PlannerState {
  status: "idle" | "planning" | "planned" | "refused" | "unreachable";
  message: string;
  planningTime: number | null;
  goalJoints: number[];
}

export interface RunState {
  status: "moving" | "done" | "stopped";
  finalPosition: Vec3 | null;
  finalError: number | null;
  rmsGap: number | null;
  maxGap: number | null;
  contacts: Array<{ a: string; b: string }>;
  contactSteps: number;
  samples: number;
  simTime: number;
  wallTime: number;
}

export interface TaskState {
  phase: Phase;
  obstacles: TaskBox[];
  object: (TaskBox & { held: boolean }) | null;
  goal: Vec3;
  planner: PlannerState;
  run: RunState | null;
}

/** What the session needs from the app. */
export interface TaskHost {
  viewer: Viewer;
  connection: RosConnection;
  /** Move the robot (sliders and view follow). */
  setJoints(values: Record<string, number>): void;
  /** Allow or block the joint sliders. */
  lockJoints(locked: boolean): void;
  /** The PlanTask service that plans for `robot` (a catalog name), or null when no
   * planner on this server plans for it. */
  planService(robot: string): string | null;
  /** "compiling" while the server's planner compiles its kernels, else "ready" or null. */
  plannerStatus(): string | null;
}

export class TaskSession {
  readonly editor: TaskEditor;
  private robot: Robot | null = null;
  private robotName = "";
  private worldName = "";
  private phase: Phase = "editing";
  private start: Arrangement | null = null;
  private held = false;
  private planner: PlannerState = {
    status: "idle",
    message: "",
    planningTime: null,
    goalJoints: [],
  };
  private runState: RunState | null = null;
  private run: MotionRun | null = null;
  private physics: Promise<PhysicsWorld> | null = null;
  /** What `physics` was built for (the start arrangement and whether the object is held). */
  private physicsKey = "";
  private bundle: Promise<MjcfBundle> | null = null;
  private nextObstacle = 1;
  private readonly plannerClient: PlannerClient;
  private lastResult: RunResult | null = null;

  constructor(
    private readonly host: TaskHost,
    private readonly panel: TaskPanel,
    private readonly plot: HTMLElement,
  ) {
    this.editor = new TaskEditor(
      host.viewer,
      (pick) => {
        if (pick.kind === "goal") panel.showGoal(this.editor.goal());
        else if (pick.kind === "object") panel.showObject(this.editor.object());
        else panel.showObstacles(this.editor.obstacles());
      },
      (pick) => panel.showSelection(pick),
    );
    this.plannerClient = new PlannerClient(host.connection, (reference) =>
      this.onReference(reference),
    );
    host.connection.onChange(() => this.showPhase());
  }

  /** Work with `robot` (an arm) in `world`; the arrangement resets to the paper's start. */
  attach(robot: Robot, robotName: string, worldName: string): void {
    this.stop();
    const sameRobot = this.robotName === robotName && this.worldName === worldName;
    this.robot = robot;
    this.robotName = robotName;
    this.worldName = worldName;
    if (!sameRobot) {
      this.bundle = null;
      this.dropPhysics();
    }
    this.editor.group.visible = true;
    this.panel.setVisible(true);
    this.phase = "editing";
    this.host.lockJoints(false);
    this.editor.setLocked(false);
    if (!sameRobot || !this.editor.object()) {
      this.editor.setGoal([0.18, 0.2, 0.02]);
      this.panel.showGoal(this.editor.goal());
      this.panel.showObject(this.editor.object());
      this.panel.showObstacles(this.editor.obstacles());
    }
    this.say(wording.ARRANGE);
    this.showPhase();
    // Fetch the physics model and MuJoCo when the page is idle, so Move Robot! does
    // not wait for them.
    this.bundleFor();
    whenIdle(() => void mujoco().catch(() => undefined));
  }

  /** Nothing to do here (a robot without an arm): hide the task. */
  detach(): void {
    this.stop();
    this.robot = null;
    this.editor.group.visible = false;
    this.panel.setVisible(false);
    this.plot.hidden = true;
    this.host.viewer.requestRender();
  }

  state(): TaskState {
    const object = this.editor.object();
    return {
      phase: this.phase,
      obstacles: this.editor.obstacles(),
      object: object ? { ...object, held: this.phase !== "editing" && this.held } : null,
      goal: this.editor.goal(),
      planner: { ...this.planner, goalJoints: [...this.planner.goalJoints] },
      run: this.runState ? { ...this.runState, contacts: [...this.runState.contacts] } : null,
    };
  }

  /** The physics model of the arrangement, built if needed (for measuring its speed). */
  physicsWorld(): Promise<PhysicsWorld> {
    return this.ensurePhysics();
  }

  // --- the four buttons --------------------------------------------------------------

  /** Fix the start posture, the object and the goal. */
  setRobot(): void {
    if (this.phase !== "editing" || !this.robot) return;
    this.start = this.arrangement();
    // The gripper stays as the user left it: the planner models the fingers at their
    // zero (closed) position, so opening them here would move them where it never looked.
    this.held = this.objectInHand() !== null;
    this.phase = "set";
    this.host.lockJoints(true);
    this.editor.setLocked(true);
    this.showPhase();
    this.say(wording.robotSet(this.start.object ? this.held : null));
    // Build the physics now (and let the browser compile its hot code) while the user
    // reads; Move Robot! then starts at once.
    this.ensurePhysics().catch((err) => console.warn("physics:", wording.errorText(err)));
  }

  addObstacle(): void {
    if (this.phase !== "editing") return;
    const id = this.freeObstacleId();
    this.editor.putObstacle({
      id,
      size: [...DEFAULT_OBSTACLE_SIZE],
      position: [0.2, 0, DEFAULT_OBSTACLE_SIZE[2] / 2 + 0.05],
      quaternion: [0, 0, 0, 1],
    });
    this.panel.showObstacles(this.editor.obstacles());
    this.editor.select({ kind: "obstacle", id });
  }

  /** Back to the start posture, everything editable again. */
  resetRobot(): void {
    this.stop();
    if (this.start && this.robot) {
      this.host.setJoints(this.start.joints);
      this.editor.setObject(this.start.object);
    }
    this.phase = "editing";
    this.host.lockJoints(false);
    this.editor.setLocked(false);
    this.editor.showPaths([], []);
    this.plot.hidden = true;
    this.showPhase();
    this.say(wording.EDITABLE_AGAIN);
  }

  /** Plan with the server, then move in the browser's physics. */
  async moveRobot(): Promise<void> {
    if (this.phase === "editing") this.setRobot();
    if ((this.phase !== "set" && this.phase !== "done") || !this.start || !this.robot) return;
    if (this.phase === "done") this.restoreStart();
    const arrangement = this.start;
    const names = this.robot.joints.map((j) => j.name);
    this.phase = "planning";
    this.planner = { status: "planning", message: "", planningTime: null, goalJoints: [] };
    this.runState = null;
    this.showPhase();
    this.say(wording.PLANNING);
    let response: PlanTaskResponse;
    try {
      const service = this.host.planService(this.robotName) ?? "/robotrial/plan_task";
      response = await this.plannerClient.plan(arrangement, names, service, () => {
        if (this.phase === "planning") this.say(wording.STILL_PLANNING);
      });
    } catch (err) {
      this.planner = { ...this.planner, status: "unreachable", message: wording.errorText(err) };
      this.plot.hidden = true;
      this.phase = "set";
      this.showPhase();
      this.say(wording.unreachable(err), "error");
      return;
    }
    if (!response.success) {
      this.planner = {
        status: "refused",
        message: response.message,
        planningTime: response.planning_time,
        goalJoints: [],
      };
      // the chart was the last run's; it says nothing of a plan that was refused
      this.plot.hidden = true;
      this.editor.showPaths([], []);
      this.phase = "set";
      this.showPhase();
      this.say(wording.refused(response), "error");
      return;
    }
    // Whether the object moves with the hand is the server's call, made once.
    this.held = response.object_held;
    this.planner = {
      status: "planned",
      message: response.message,
      planningTime: response.planning_time,
      goalJoints: [...response.goal_joints],
    };
    try {
      const reference = await this.plannerClient.reference(response, names, arrangement.joints);
      await this.play(reference);
    } catch (err) {
      if ((this.phase as Phase) === "moving") {
        this.phase = "set";
        this.showPhase();
        this.say(wording.motionFailed(err), "error");
      }
    }
  }

  // --- editing from the panel ----------------------------------------------------------

  editObstacle(box: TaskBox): void {
    this.editor.putObstacle(box);
    this.panel.showObstacles(this.editor.obstacles());
  }

  removeObstacle(id: string): void {
    this.editor.removeObstacle(id);
    this.panel.showObstacles(this.editor.obstacles());
  }

  carryObject(on: boolean): void {
    if (on && !this.editor.object()) this.objectToHand();
    if (!on) this.editor.setObject(null);
    this.panel.showObject(this.editor.object());
  }

  editObject(box: TaskBox): void {
    this.editor.setObject({ ...box, id: "object" });
    this.panel.showObject(this.editor.object());
  }

  /** Put the object between the fingers: centred on the hand's axis, just behind the tcp. */
  objectToHand(): void {
    if (!this.robot) return;
    const size = this.editor.object()?.size ?? DEFAULT_OBJECT_SIZE;
    const tcp = this.tcpInBase();
    const back = Math.max(0, size[2] / 2 - 0.0025);
    const centre = new Vector3(0, 0, -back).applyMatrix4(tcp);
    const q = new Quaternion().setFromRotationMatrix(tcp);
    this.editor.setObject({
      id: "object",
      size: [...size],
      position: [centre.x, centre.y, centre.z],
      quaternion: [q.x, q.y, q.z, q.w],
    });
    this.panel.showObject(this.editor.object());
  }

  editGoal(goal: Vec3): void {
    this.editor.setGoal(goal);
    this.panel.showGoal(this.editor.goal());
  }

  // --- scene files ---------------------------------------------------------------------

  saveScene(): void {
    saveSceneFile(
      this.start && this.phase !== "editing" ? this.start : this.arrangement(),
      this.robotName,
      this.worldName,
    );
    this.say(wording.SCENE_SAVED, "ok");
  }

  /** Load a scene; returns the robot and world it names, for the app to switch to. */
  async loadScene(file: File): Promise<Arrangement | null> {
    let scene: Arrangement;
    try {
      scene = parseSceneFile(await file.text());
    } catch (err) {
      this.say(wording.sceneNotLoaded(file.name, err), "error");
      return null;
    }
    return scene;
  }

  /** Show a loaded scene (the app has already switched to its robot and world). */
  applyScene(scene: Arrangement): void {
    if (this.phase !== "editing") this.resetRobot();
    this.editor.clearObstacles();
    for (const box of scene.obstacles) this.editor.putObstacle(box);
    this.editor.setObject(scene.object ? { ...scene.object, id: "object" } : null);
    this.editor.setGoal(scene.goal);
    this.host.setJoints(scene.joints);
    this.panel.showObstacles(this.editor.obstacles());
    this.panel.showObject(this.editor.object());
    this.panel.showGoal(this.editor.goal());
    this.say(wording.SCENE_LOADED, "ok");
  }

  // --- the plot --------------------------------------------------------------------------

  async exportPlot(kind: "csv" | "png"): Promise<void> {
    const result = this.lastResult;
    if (!result) return;
    await savePath(kind, this.robotName, result.samples, () => this.chart(result));
  }

  // --- internals -------------------------------------------------------------------------

  private arrangement(): Arrangement {
    return {
      robot: this.robotName,
      world: this.worldName,
      joints: this.robot ? this.robot.valuesByName() : {},
      obstacles: this.editor.obstacles(),
      object: this.editor.object(),
      goal: this.editor.goal(),
    };
  }

  private restoreStart(): void {
    if (!this.start) return;
    this.host.setJoints(this.start.joints);
    this.editor.setObject(this.start.object);
    this.editor.showPaths([], []);
  }

  /** The object's pose in the tcp frame when it is within reach of the hand, else null. */
  private objectInHand(): { position: Vec3; quaternion: Quat } | null {
    const box = this.editor.object();
    if (!box || !this.robot) return null;
    const objectPose = new Matrix4().compose(
      new Vector3(...box.position),
      new Quaternion(...box.quaternion),
      new Vector3(1, 1, 1),
    );
    const inTcp = this.tcpInBase().invert().multiply(objectPose);
    const p = new Vector3();
    const q = new Quaternion();
    inTcp.decompose(p, q, new Vector3());
    // Distance from the tcp to the box: the tcp in the box's frame, outside its extent.
    const tcpInBox = new Vector3().applyMatrix4(
      new Matrix4().compose(p, q, new Vector3(1, 1, 1)).invert(),
    );
    const gap = new Vector3(
      Math.max(0, Math.abs(tcpInBox.x) - box.size[0] / 2),
      Math.max(0, Math.abs(tcpInBox.y) - box.size[1] / 2),
      Math.max(0, Math.abs(tcpInBox.z) - box.size[2] / 2),
    ).length();
    if (gap > HOLD_DISTANCE) return null;
    return { position: [p.x, p.y, p.z], quaternion: [q.x, q.y, q.z, q.w] };
  }

  private tcpInBase(): Matrix4 {
    const robot = this.robot!;
    robot.root.updateWorldMatrix(true, true);
    return new Matrix4().copy(robot.root.matrixWorld).invert().multiply(robot.tcp.matrixWorld);
  }

  private bundleFor(): Promise<MjcfBundle> {
    this.bundle ??= fetchMjcf(this.robotName, this.worldName);
    this.bundle.catch(() => (this.bundle = null));
    return this.bundle;
  }

  /** The physics of the start arrangement: built once per arrangement and warmed up. */
  private async ensurePhysics(): Promise<PhysicsWorld> {
    const robot = this.robot;
    if (!robot) throw new Error("no robot is loaded");
    const start = this.start ?? this.arrangement();
    const held = this.phase !== "editing" && this.held ? this.objectInHandAt(start) : null;
    const key = JSON.stringify([start, held]);
    if (!this.physics || key !== this.physicsKey) {
      this.dropPhysics();
      this.physicsKey = key;
      this.physics = this.bundleFor().then(async (bundle) => {
        const world = await PhysicsWorld.create(
          bundle,
          { obstacles: start.obstacles, object: start.object, heldAt: held },
          robot.root.name,
        );
        world.reset(start.joints);
        world.measureSpeed(0.3);
        return world;
      });
      this.physics.catch(() => {
        if (this.physicsKey === key) this.dropPhysics();
      });
    }
    return this.physics;
  }

  private dropPhysics(): void {
    const old = this.physics;
    this.physics = null;
    this.physicsKey = "";
    old?.then((w) => w.dispose()).catch(() => undefined);
  }

  /** The held object's pose in the tcp frame for the start posture. */
  private objectInHandAt(start: Arrangement): { position: Vec3; quaternion: Quat } | null {
    const now = this.robot!.valuesByName();
    this.robot!.setJoints(start.joints);
    const pose = this.objectInHand();
    this.robot!.setJoints(now);
    return pose;
  }

  /** A motion arrived on the topic: one from elsewhere (another ROS tool) moves a set
   * robot too. */
  private onReference(reference: JointReference): void {
    if ((this.phase === "set" || this.phase === "done") && !this.run) {
      if (this.phase === "done") this.restoreStart();
      void this.play(reference).catch((err) => this.say(wording.motionFailed(err), "error"));
    }
  }

  private async play(reference: JointReference): Promise<void> {
    const robot = this.robot;
    if (!robot) return;
    this.phase = "moving";
    this.showPhase();
    this.say(wording.MOVING);
    const world = await this.ensurePhysics();
    world.reset((this.start ?? this.arrangement()).joints);
    const tracker = new JointTracker(world);
    const planned: Vec3[] = [];
    for (let t = 0; t <= reference.duration + 1e-9; t += 0.02) {
      planned.push(world.tcpAt(reference.byName(reference.sample(t).q)));
    }
    planned.push(world.tcpAt(reference.end()));
    this.editor.showPaths(planned, []);
    const driven = new Set(robot.joints.map((j) => j.name));
    const run = new MotionRun(
      world,
      tracker,
      reference,
      this.start?.goal ?? this.editor.goal(),
      (r) => {
        const values = world.jointValues();
        this.host.setJoints(
          Object.fromEntries(Object.entries(values).filter(([n]) => driven.has(n))),
        );
        const pose = world.objectPose();
        if (pose) this.editor.moveObject(pose.position, pose.quaternion);
        this.runState = {
          status: "moving",
          finalPosition: null,
          finalError: null,
          rmsGap: null,
          maxGap: null,
          contacts: [],
          contactSteps: 0,
          samples: r.path().length,
          simTime: world.time - r.started,
          wallTime: 0,
        };
      },
    );
    this.run = run;
    let result: RunResult;
    try {
      result = await run.play();
    } finally {
      if (this.run === run) this.run = null;
    }
    this.lastResult = result;
    this.runState = {
      status: "done",
      finalPosition: result.finalPosition,
      finalError: result.finalError,
      rmsGap: result.rmsGap,
      maxGap: result.maxGap,
      contacts: result.contacts,
      contactSteps: result.contactSteps,
      samples: result.samples.length,
      simTime: result.simTime,
      wallTime: result.wallTime,
    };
    this.editor.showPaths(
      result.samples.map((s) => s.planned),
      result.samples.map((s) => s.simulated),
    );
    this.phase = "done";
    this.showPhase();
    this.showPlot(result);
    this.say(...wording.runSummary(result));
  }

  private showPlot(result: RunResult): void {
    const csv = this.plot.querySelector<HTMLButtonElement>("#export-csv");
    const png = this.plot.querySelector<HTMLButtonElement>("#export-png");
    const chart = this.plot.querySelector<HTMLElement>(".chart");
    if (!csv || !png || !chart) return;
    chart.replaceChildren(chartImage(this.chart(result)));
    this.plot.hidden = false;
  }

  private chart(result: RunResult): SVGSVGElement {
    return pathChart({
      samples: result.samples,
      obstacles: this.start?.obstacles ?? [],
      goal: this.start?.goal ?? this.editor.goal(),
    });
  }

  private stop(): void {
    if (this.run) {
      this.run.cancel();
      this.run = null;
      if (this.runState) this.runState = { ...this.runState, status: "stopped" };
    }
  }

  private freeObstacleId(): string {
    const taken = new Set(this.editor.obstacles().map((b) => b.id));
    while (taken.has(`obstacle${this.nextObstacle}`)) this.nextObstacle += 1;
    return `obstacle${this.nextObstacle++}`;
  }

  private showPhase(): void {
    const connected = this.host.connection.state().status === "connected";
    const planned = this.host.planService(this.robotName) !== null;
    this.panel.setPhase(this.phase, connected && this.robot !== null && planned);
    if (this.phase === "editing" && this.robot && !planned) {
      this.say(wording.noPlanner(this.robotName));
    } else if (this.phase === "editing" && this.robot && this.host.plannerStatus() === "compiling") {
      this.say(wording.plannerCompiling());
    }
  }

  /** The server's planner changed (a robot added, compiling done): show what it allows. */
  plannerChanged(): void {
    this.showPhase();
  }

  private say(text: string, kind: MessageKind = "info"): void {
    this.panel.say(text, kind);
  }
}

/** Run `task` when the page is idle (soon after the first frame), where browsers can say. */
function whenIdle(task: () => void): void {
  if ("requestIdleCallback" in window) requestIdleCallback(task, { timeout: 3000 });
  else setTimeout(task, 1500);
}
