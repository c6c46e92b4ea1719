// The page's controller: loads a robot into a world, wires the panel to the robot's
// joints, and keeps the state that window.robotrial.state() reports.

import {
  getCatalog,
  getConfig,
  robotFileUrl,
  worldFileUrl,
  type Catalog,
  type Spawn,
} from "./api";
import { loadRobot, type Robot } from "./robot";
import { enableShadows, Viewer } from "./scene";
import type { RobotrialState } from "./state";
import { humanize } from "./ui/dom";
import { Panel } from "./ui/panel";
import { loadWorld, placeAt } from "./world";

const ORIGIN: Spawn = { xyz: [0, 0, 0], quat: [0, 0, 0, 1] };

export class RobotrialApp {
  readonly viewer: Viewer;
  readonly panel: Panel;
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
    });
  }

  /** Read the server's catalog and open the robot and world asked for in the URL
   * (?robot=…&world=…) or, failing that, the server's defaults. */
  async start(): Promise<void> {
    try {
      const [config, catalog] = await Promise.all([getConfig(), getCatalog()]);
      this.catalog = catalog;
      this.panel.setCatalog(catalog.robots, catalog.worlds);
      const query = new URLSearchParams(location.search);
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
    this.panel.setStatus(`Loading ${humanize(robotName)}…`, "loading");
    const spawn = this.catalog.worlds.find((w) => w.name === worldName)?.spawn;
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
      this.viewer.frame(robot.object);
      this.panel.setJoints(robot.joints, robot.jointValues());
      this.panel.describeEndEffector(
        robot.description.tcp,
        robot.joints.some((j) => j.group === "arm" || j.group === "gripper"),
      );
      this.panel.setEndEffector(robot.endEffector());
      await this.viewer.rendered();
      if (load !== this.loads) return;
      this.ready = true;
      performance.measure(`robotrial:ready ${robotName} ${worldName}`, { start: started });
      this.panel.setStatus(`${humanize(robotName)} · ${humanize(worldName)}`, "ready");
      const query = new URLSearchParams({ robot: robotName, world: worldName });
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
      ready: this.ready,
      error: this.error,
    };
  }

  private fail(err: unknown): void {
    this.ready = false;
    this.error = err instanceof Error ? err.message : String(err);
    this.panel.setStatus(`Could not load: ${this.error}`, "error");
    console.error(err);
  }
}
