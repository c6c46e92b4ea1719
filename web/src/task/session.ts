// The g2rViewer workflow for an arm: arrange obstacles, the object and the goal; Set
// Robot fixes the start; Move Robot! asks the planner (/robotrial/plan_task through
// rosbridge) and plays its answer in the browser's physics; Reset Robot goes back to
// editing. Also the scene file, and the plot of the hand's path.

import { Matrix4, Quaternion, Vector3 } from "three";
import { type JointTrajectory, PlanTaskResponse } from "../generated/msgs";
import { JointReference, JointTracker } from "../physics/controller";
import { fetchMjcf, type MjcfBundle, mujoco, PhysicsWorld } from "../physics/world";
import type { Robot } from "../robot";
import type { RosConnection } from "../ros/connection";
import type { Viewer } from "../scene";
import {
  type Arrangement,
  DEFAULT_OBJECT_SIZE,
  DEFAULT_OBSTACLE_SIZE,
  parseSceneFile,
  planRequest,
  type Quat,
  sceneFile,
  type TaskBox,
  type Vec3,
} from "./arrangement";
import { humanize } from "../ui/dom";
import { TaskEditor } from "./editor";
import type { MessageKind, Phase, TaskPanel } from "./panel";
import { chartImage, chartPng, download, pathChart, pathCsv } from "./plot";
import { MotionRun, type RunResult } from "./run";

/** An object this close to the hand (m, from the tcp to the box) is in the hand: the
 * planner's rule (robotrial.planning.task.HOLD_DISTANCE). */
const HOLD_DISTANCE = 0.05;
/** How long to wait for /robotrial/joint_reference when the answer has no trajectory. */
const REFERENCE_WAIT_MS = 5000;
/** When to tell the user that planning takes longer than usual, and when to give up (ms). */
const PATIENCE_MS = 5000;
const PLAN_TIMEOUT_MS = 120_000;
/** Speed of the fallback move to the goal joints when no trajectory comes (rad/s). */
const FALLBACK_SPEED = 0.5;

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
  /** The robot the server's planner plans for (its catalog name). */
  plannerRobot(): string;
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
  private lastReference: JointReference | null = null;
  private referenceWaiters: Array<(r: JointReference) => void> = [];
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
    host.connection.subscribe("/robotrial/joint_reference", (msg) => this.onReference(msg));
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
    this.say("Arrange the scene, press Set Robot, then Move Robot!");
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
    const object = this.start.object
      ? this.held
        ? " The object is in the hand."
        : " The object is not in the hand: it stays where it is."
      : "";
    this.say(`Robot set.${object} Press Move Robot! to plan and move.`);
    // Build the physics now (and let the browser compile its hot code) while the user
    // reads; Move Robot! then starts at once.
    this.ensurePhysics().catch((err) => console.warn("physics:", errorText(err)));
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
    this.showPhase();
    this.say("The robot and the object can be moved again.");
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
    this.lastReference = null;
    this.showPhase();
    this.say("Planning a path…");
    // The first plan after the server starts also prepares the planner: say so.
    const patience = window.setTimeout(() => {
      if (this.phase === "planning") {
        this.say("Still planning… the first plan after the server starts can take a minute.");
      }
    }, PATIENCE_MS);
    let response: PlanTaskResponse;
    try {
      response = await this.host.connection.call(
        "/robotrial/plan_task",
        planRequest(arrangement, names),
        PLAN_TIMEOUT_MS,
      );
    } catch (err) {
      this.planner = { ...this.planner, status: "unreachable", message: errorText(err) };
      this.phase = "set";
      this.showPhase();
      this.say(`Could not reach the planner: ${errorText(err)}`, "error");
      return;
    } finally {
      window.clearTimeout(patience);
    }
    if (!response.success) {
      this.planner = {
        status: "refused",
        message: response.message,
        planningTime: response.planning_time,
        goalJoints: [],
      };
      this.phase = "set";
      this.showPhase();
      this.say(`The planner says no: ${plainReason(response)}`, "error");
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
      const reference = await this.referenceFor(response, arrangement);
      await this.play(reference);
    } catch (err) {
      if ((this.phase as Phase) === "moving") {
        this.phase = "set";
        this.showPhase();
        this.say(`The motion could not run: ${errorText(err)}`, "error");
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
    const blob = new Blob(
      [sceneFile(this.start && this.phase !== "editing" ? this.start : this.arrangement())],
      {
        type: "application/json",
      },
    );
    download(blob, `${this.robotName}-${this.worldName}-scene.json`);
    this.say("Scene saved as a file.", "ok");
  }

  /** Load a scene; returns the robot and world it names, for the app to switch to. */
  async loadScene(file: File): Promise<Arrangement | null> {
    let scene: Arrangement;
    try {
      scene = parseSceneFile(await file.text());
    } catch (err) {
      this.say(`Could not load ${file.name}: ${errorText(err)}`, "error");
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
    this.say("Scene loaded.", "ok");
  }

  // --- the plot --------------------------------------------------------------------------

  async exportPlot(kind: "csv" | "png"): Promise<void> {
    const result = this.lastResult;
    if (!result) return;
    const stem = `${this.robotName}-hand-path`;
    if (kind === "csv") {
      download(new Blob([pathCsv(result.samples)], { type: "text/csv" }), `${stem}.csv`);
    } else {
      download(await chartPng(this.chart(result)), `${stem}.png`);
    }
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

  private async referenceFor(
    response: PlanTaskResponse,
    start: Arrangement,
  ): Promise<JointReference> {
    if (response.trajectory.points.length > 0) return new JointReference(response.trajectory);
    // A ROS system that answers with goal joints only sends the motion on the topic.
    const fromTopic = await new Promise<JointReference | null>((resolve) => {
      if (this.lastReference) return resolve(this.lastReference);
      const timer = setTimeout(() => resolve(null), REFERENCE_WAIT_MS);
      this.referenceWaiters.push((r) => {
        clearTimeout(timer);
        resolve(r);
      });
    });
    if (fromTopic) return fromTopic;
    const names = this.robot!.joints.map((j) => j.name).slice(0, response.goal_joints.length);
    const from = names.map((n) => start.joints[n] ?? 0);
    const span = Math.max(...response.goal_joints.map((g, i) => Math.abs(g - from[i])), 1e-3);
    const trajectory: JointTrajectory = {
      header: { stamp: { sec: 0, nanosec: 0 }, frame_id: "" },
      joint_names: names,
      points: [from, response.goal_joints].map((positions, i) => ({
        positions,
        velocities: names.map(() => 0),
        accelerations: [],
        effort: [],
        time_from_start: { sec: i * Math.ceil(span / FALLBACK_SPEED), nanosec: 0 },
      })),
    };
    return new JointReference(trajectory);
  }

  private onReference(msg: JointTrajectory): void {
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
    // A reference from elsewhere (another ROS tool) moves a set robot too.
    if ((this.phase === "set" || this.phase === "done") && !this.run) {
      if (this.phase === "done") this.restoreStart();
      void this.play(reference).catch((err) =>
        this.say(`The motion could not run: ${errorText(err)}`, "error"),
      );
    }
  }

  private async play(reference: JointReference): Promise<void> {
    const robot = this.robot;
    if (!robot) return;
    this.phase = "moving";
    this.showPhase();
    this.say("Moving…");
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
    this.say(...summary(result));
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
    const ours = this.robotName === this.host.plannerRobot();
    this.panel.setPhase(this.phase, connected && this.robot !== null && ours);
    if (this.phase === "editing" && this.robot && !ours) {
      this.say(
        `The planner on this server plans for the ` +
          `${humanize(this.host.plannerRobot()).toLowerCase()}; ` +
          "this robot can be arranged but not moved.",
      );
    }
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

/** The message for the end of a run, and whether it is good news. */
function summary(r: RunResult): [string, MessageKind] {
  const length = (m: number) =>
    m < 0.001
      ? "less than 1 mm"
      : m < 0.01
        ? `${(m * 1000).toFixed(1)} mm`
        : `${(m * 100).toFixed(1)} cm`;
  const touched = r.contacts.length
    ? `it touched ${[...new Set(r.contacts.map((c) => c.b))].join(", ")} (${r.contacts
        .map((c) => c.a)
        .join(", ")})`
    : "no contact with obstacles";
  const reached = r.finalError <= 0.01;
  const text =
    `${reached ? "Done" : "Finished"}: the hand is ${length(r.finalError)} from the goal; ` +
    `${touched}; ` +
    `it followed the plan within ${length(r.rmsGap)} (RMS).`;
  return [text, reached && r.contacts.length === 0 ? "ok" : "error"];
}

/** The planner's reason, said plainly from its error code, with the message's details. */
function plainReason(response: PlanTaskResponse): string {
  const plain: Record<number, string> = {
    [PlanTaskResponse.NO_IK_SOLUTION]: "the goal is out of the arm's reach",
    [PlanTaskResponse.START_STATE_IN_COLLISION]: "the robot starts out touching something",
    [PlanTaskResponse.GOAL_IN_COLLISION]:
      "the hand cannot be at the goal without touching something",
    [PlanTaskResponse.TIMED_OUT]: "no way around the obstacles was found in time",
    [PlanTaskResponse.INVALID_MOTION_PLAN]: "no path the robot can follow safely was found",
    [PlanTaskResponse.INVALID_GOAL_CONSTRAINTS]: "the request is not one the planner can take",
  };
  const message = response.message;
  const said = plain[response.error_code];
  if (!said) return message || "no reason given.";
  // The message is "<what>: <details>"; the details say which link, how far, how long.
  const colon = message.indexOf(":");
  const detail = (colon >= 0 ? message.slice(colon + 1) : message).trim().replace(/\.$/, "");
  if (!detail) return `${said}.`;
  return `${said}. ${detail.charAt(0).toUpperCase()}${detail.slice(1)}.`;
}

function errorText(err: unknown): string {
  return err instanceof Error ? err.message : String(err);
}
