// The page's controller: loads a robot into a world, wires the panel to the robot's
// joints, keeps the rosbridge connection and, for arms, the task (task/session.ts), and
// the state that window.robotrial.state() reports.

import {
  getCatalog,
  getConfig,
  robotFileUrl,
  worldFileUrl,
  type Catalog,
  type Config,
  type SpawnPose,
  type UploadAnswer,
  type WorldEntry,
} from "./api";
import { ArView, installEmulatorIfAsked } from "./ar/ar";
import { LiveView } from "./live/live";
import { loadRobot, type Robot } from "./robot";
import { checkRosbridgeUrl, RosConnection, sameOriginUrl } from "./ros/connection";
import { enableShadows, Viewer } from "./scene";
import type { PhysicsSpeed, RobotrialState } from "./state";
import { TaskPanel } from "./task/panel";
import { TaskSession } from "./task/session";
import { el, humanize, robotTitle } from "./ui/dom";
import { Panel } from "./ui/panel";
import { HomeSection } from "./home/editor";
import { chooseTool, UploadSection } from "./upload/upload";
import { loadWorld, placeAt, standing } from "./world";

const ORIGIN: SpawnPose = { xyz: [0, 0, 0], quat: [0, 0, 0, 1] };

export class RobotrialApp {
  readonly viewer: Viewer;
  readonly panel: Panel;
  readonly connection = new RosConnection();
  readonly task: TaskSession;
  readonly ar: ArView;
  readonly live: LiveView;
  private config: Config | null = null;
  private catalog: Catalog = { default: { robot: "", world: "" }, robots: [], worlds: [] };
  private robotName = "";
  private worldName = "";
  private robot: Robot | null = null;
  /** The catalog name of the robot on screen. */
  private robotShown = "";
  private ready = false;
  private error: string | null = null;
  /** Counts loads, so that a slow load finishing after a newer one is dropped. */
  private loads = 0;

  constructor(view: HTMLElement, panel: HTMLElement) {
    this.viewer = new Viewer(view);
    this.panel = new Panel(panel, {
      pick: (robot, world) => void this.load(robot, world),
      moveJoint: (name, value) => this.setJoints({ [name]: value }),
      home: () => this.home(),
      chooseTool: (link) => void this.chooseTool(link),
    });
    const taskPanel = new TaskPanel({
      setRobot: () => this.task.setRobot(),
      addObstacle: () => this.task.addObstacle(),
      resetRobot: () => this.task.resetRobot(),
      moveRobot: () => void this.task.moveRobot(),
      editObstacle: (box) => this.task.editObstacle(box),
      removeObstacle: (id) => this.task.removeObstacle(id),
      carryObject: (on) => this.task.carryObject(on),
      editObject: (box) => this.task.editObject(box),
      objectToHand: () => this.task.objectToHand(),
      editGoal: (goal) => this.task.editGoal(goal),
      select: (pick) => this.task.editor.select(pick),
      gizmoMode: (mode) => this.task.editor.setMode(mode),
      saveScene: () => this.task.saveScene(),
      loadScene: (file) => void this.loadScene(file),
      connect: (url) => this.connect(url),
    });
    this.panel.mount(taskPanel.indicator, "header");
    this.panel.mount(taskPanel.main, "top");
    this.panel.mount(taskPanel.details);
    const plot = plotCard(view, (kind) => void this.task.exportPlot(kind));
    this.task = new TaskSession(
      {
        viewer: this.viewer,
        connection: this.connection,
        setJoints: (values) => this.setJoints(values),
        lockJoints: (locked) => this.panel.lockJoints(locked),
        planService: (robot) => this.planService(robot),
        plannerStatus: () => this.config?.planner ?? null,
      },
      taskPanel,
      plot,
    );
    this.connection.onChange((state) => taskPanel.showConnection(state));
    this.live = new LiveView(this.viewer, this.connection, (v) => this.setJoints(v));
    this.panel.mount(this.live.section, "top");
    const home = new HomeSection((entry) => this.addWorld(entry));
    this.ar = new ArView(this.viewer, () => this.robot?.object.parent ?? null, (next) => home.edit(next));
    this.panel.mount(this.ar.section);
    this.panel.mount(new UploadSection((answer) => this.addUploadedRobot(answer)).section);
    this.panel.mount(home.section);
  }

  /** The PlanTask service for `robot`: the server's default robot answers on
   * /robotrial/plan_task (as a g2rViewer server does), the others on their own. */
  private planService(robot: string): string | null {
    const config = this.config;
    if (!config) return null;
    if (robot === config.robot) return "/robotrial/plan_task";
    return config.plan_services?.[robot] ?? null;
  }

  /** Read the server's config again until its planner has compiled. */
  private async watchPlanner(): Promise<void> {
    while (this.config?.planner === "compiling") {
      await new Promise((resolve) => setTimeout(resolve, 2000));
      this.config = await getConfig();
      this.task.plannerChanged();
    }
  }

  /** A robot the server accepted from an upload: list it in the picker and open it. */
  async addUploadedRobot(answer: UploadAnswer): Promise<void> {
    this.config = await getConfig();
    this.catalog = await getCatalog();
    this.panel.setCatalog(this.catalog.robots, this.catalog.worlds);
    await this.load(answer.robot.name, answer.robot.world);
    if (this.error) throw new Error(this.error);
  }

  /** Make `link` the tool of the (uploaded) robot on screen, and show it again with it. */
  async chooseTool(link: string): Promise<void> {
    const name = this.robotName;
    try {
      await chooseTool(name, link);
      this.config = await getConfig();
      this.catalog = await getCatalog();
      this.panel.setCatalog(this.catalog.robots, this.catalog.worlds);
      this.robotShown = ""; // its file changed: load it again
      await this.load(name, this.worldName);
    } catch (err) {
      this.fail(err);
    }
  }

  /** A world the server accepted (a home drawn in the page): list it and show a robot
   * of its kind in it (the one on screen if it suits). */
  async addWorld(entry: WorldEntry): Promise<void> {
    this.catalog = await getCatalog();
    this.panel.setCatalog(this.catalog.robots, this.catalog.worlds);
    const current = this.catalog.robots.find((r) => r.name === this.robotName);
    const robot =
      current?.kind === entry.kind
        ? current
        : this.catalog.robots.find((r) => r.kind === entry.kind) ?? current;
    await this.load(robot?.name ?? this.robotName, entry.name);
    if (this.error) throw new Error(this.error);
  }

  /** Point the page at another rosbridge (a real ROS system offering the same names). */
  connect(url: string): void {
    try {
      this.connection.open(checkRosbridgeUrl(url));
    } catch (err) {
      this.panel.setStatus(err instanceof Error ? err.message : String(err), "error");
    }
  }

  /** MuJoCo steps per second of wall time for the robot and scene on screen. */
  async measurePhysics(seconds = 1): Promise<PhysicsSpeed> {
    const world = await this.task.physicsWorld();
    return world.measureSpeed(seconds);
  }

  private async loadScene(file: File): Promise<void> {
    const scene = await this.task.loadScene(file);
    if (!scene) return;
    if (scene.robot !== this.robotName || scene.world !== this.worldName) {
      await this.load(scene.robot, scene.world);
      if (!this.ready) return;
    }
    this.task.applyScene(scene);
  }

  /** Read the server's catalog and open the robot and world asked for in the URL
   * (?robot=…&world=…) or, failing that, the server's defaults. */
  async start(): Promise<void> {
    try {
      const [config, catalog] = await Promise.all([getConfig(), getCatalog()]);
      this.config = config;
      void this.watchPlanner();
      this.live.setInfo(config.live ?? null);
      await installEmulatorIfAsked();
      void this.ar.check();
      this.catalog = catalog;
      this.panel.setCatalog(catalog.robots, catalog.worlds);
      const query = new URLSearchParams(location.search);
      const rosbridge = query.get("rosbridge");
      if (rosbridge) this.connect(rosbridge);
      else if (config.rosbridge_enabled) this.connection.open(sameOriginUrl(config.rosbridge));
      await this.load(query.get("robot") ?? config.robot, query.get("world") ?? config.world);
    } catch (err) {
      this.fail(err);
    }
  }

  /** Show `robotName` in `worldName`; a robot already shown keeps its joint values.
   * Ready once the first frame with both is drawn (a performance measure
   * "robotrial:ready ROBOT WORLD" records how long that took). */
  async load(robotName: string, worldName: string): Promise<void> {
    const load = ++this.loads;
    const started = performance.now();
    this.ready = false;
    this.error = null;
    this.robotName = robotName;
    this.worldName = worldName;
    this.panel.setSelection(robotName, worldName);
    const entry = this.catalog.robots.find((r) => r.name === robotName);
    const title = entry ? robotTitle(entry) : robotName;
    this.panel.setStatus(`Loading ${title}…`, "loading");
    const spawnPose = this.catalog.worlds.find((w) => w.name === worldName)?.spawn ?? ORIGIN;
    // the server says where the robot stands in the world it opens in
    const spawn = entry && entry.world === worldName ? standing(spawnPose, entry.stand) : spawnPose;
    try {
      const keep = this.robot && this.robotShown === robotName ? this.robot : null;
      const [robot, world] = await Promise.all([
        keep ?? loadRobot(robotFileUrl(robotName)),
        loadWorld(worldFileUrl(worldName)),
      ]);
      if (load !== this.loads) return;
      if (robot !== keep) enableShadows(robot.object);
      this.robot = robot;
      this.robotShown = robotName;
      this.viewer.setWorld(world);
      this.viewer.setRobot(placeAt(robot.object, spawn ?? ORIGIN));
      const place = spawn ?? ORIGIN;
      this.task.editor.group.position.set(...place.xyz);
      this.task.editor.group.quaternion.set(...place.quat);
      const kind = this.catalog.robots.find((r) => r.name === robotName)?.kind;
      if (kind === "arm") this.task.attach(robot, robotName, worldName);
      else this.task.detach();
      this.live.shown(robotName, worldName, robot);
      this.viewer.frame(robot.object);
      this.panel.setJoints(robot.joints, robot.jointValues());
      this.panel.describeEndEffector(
        robot.description.tcp,
        robot.joints.some((j) => j.group === "arm" || j.group === "gripper"),
        entry?.uploaded ? entry.tools : [],
      );
      this.panel.setEndEffector(robot.endEffector());
      await this.viewer.rendered();
      if (load !== this.loads) return;
      this.ready = true;
      performance.measure(`robotrial:ready ${robotName} ${worldName}`, { start: started });
      this.panel.setStatus(`${title} · ${humanize(worldName)}`, "ready");
      const query = new URLSearchParams(location.search);
      query.set("robot", robotName);
      query.set("world", worldName);
      history.replaceState(null, "", `?${query}`);
    } catch (err) {
      if (load === this.loads) this.fail(err);
    }
  }

  /** Move driven joints (rad or m, clamped to their limits): the robot, the sliders,
   * the read-out and the view follow, whoever asks (a slider, a button, a trajectory). */
  setJoints(values: Record<string, number>): void {
    const robot = this.robot;
    if (!robot) return;
    robot.setJoints(values);
    const now = robot.valuesByName();
    this.panel.showJointValues(Object.fromEntries(Object.keys(values).map((n) => [n, now[n]])));
    this.panel.setEndEffector(robot.endEffector());
    this.viewer.requestRender();
  }

  /** Every driven joint back to zero (or the limit nearest to it). */
  home(): void {
    if (!this.robot) return;
    this.setJoints(Object.fromEntries(this.robot.joints.map((j) => [j.name, 0])));
  }

  state(): RobotrialState {
    const robot = this.ready ? this.robot : null;
    return {
      robot: this.robotName,
      world: this.worldName,
      joints: {
        names: robot ? robot.joints.map((j) => j.name) : [],
        values: robot ? robot.jointValues() : [],
      },
      endEffector: robot ? robot.endEffector() : null,
      tool: robot ? robot.description.tcp : "",
      ready: this.ready,
      error: this.error,
      connection: this.connection.state(),
      ...this.task.state(),
      ar: this.ar.state(),
      live: this.live.state(),
    };
  }

  private fail(err: unknown): void {
    this.ready = false;
    this.error = err instanceof Error ? err.message : String(err);
    this.panel.setStatus(`Could not load: ${this.error}`, "error");
    console.error(err);
  }
}

/** The strip docked under the 3D view that shows the hand's path after a run, with its
 * exports: the view gives up the strip's height instead of being covered; "Fold" keeps
 * only its title. */
function plotCard(view: HTMLElement, exportAs: (kind: "csv" | "png") => void): HTMLElement {
  const csv = el("button", { type: "button", class: "quiet", id: "export-csv" }, "CSV");
  const png = el("button", { type: "button", class: "quiet", id: "export-png" }, "PNG");
  const fold = el("button", { type: "button", class: "quiet", id: "plot-fold", "aria-expanded": "true" }, "Fold");
  const close = el("button", { type: "button", class: "quiet", "aria-label": "Close" }, "×");
  const card = el(
    "section",
    { class: "plot-card", id: "path-plot", hidden: "", "aria-label": "Hand path" },
    el(
      "div",
      { class: "section-head" },
      el("h2", {}, "Hand path: plan and browser"),
      el("div", { class: "row" }, csv, png, fold, close),
    ),
    el("div", { class: "chart" }),
  );
  fold.addEventListener("click", () => {
    const folded = card.classList.toggle("folded");
    fold.textContent = folded ? "Unfold" : "Fold";
    fold.setAttribute("aria-expanded", String(!folded));
  });
  csv.addEventListener("click", () => exportAs("csv"));
  png.addEventListener("click", () => exportAs("png"));
  close.addEventListener("click", () => (card.hidden = true));
  view.append(card);
  return card;
}
