// The side panel: robot and world pickers, the end-effector read-out, one slider per
// driven joint, and a status line; other parts of the page (the task, the live view,
// AR, uploads) mount their sections into it. It only shows things and reports what the
// user did; the app decides what happens.

import type { RobotEntry, WorldEntry } from "../api";
import type { ActuatedJoint } from "../robot";
import type { Vec3 } from "../types";
import { el, humanize, robotTitle } from "./dom";

export interface PanelActions {
  /** The user picked a robot (with the world it should open in) or a world. */
  pick(robot: string, world: string): void;
  /** The user moved a joint's slider (rad or m). */
  moveJoint(name: string, value: number): void;
  /** The user asked for every joint back at its home value. */
  home(): void;
  /** The user picked another link as the tool of the robot on screen. */
  chooseTool(link: string): void;
}

export type Status = "loading" | "ready" | "error";

/** Where a mounted section goes: in the header beside the status line, right under the
 * pickers, or at the end of the panel. */
export type Slot = "header" | "top" | "end";

const GROUP_TITLES: Record<string, string> = {
  arm: "Arm",
  gripper: "Gripper",
  other: "Other joints",
};

interface SliderRow {
  joint: ActuatedJoint;
  input: HTMLInputElement;
  output: HTMLOutputElement;
}

export class Panel {
  private readonly robotPicker = el("select", { id: "robot-picker", "aria-label": "Robot" });
  private readonly worldPicker = el("select", { id: "world-picker", "aria-label": "World" });
  private readonly status = el("p", { class: "status", role: "status", "aria-live": "polite" });
  private readonly effector = el("dl", { class: "effector", id: "end-effector" });
  private readonly effectorTitle = el("h2", {}, "Hand position");
  private readonly effectorHint = el("p", { class: "hint", id: "end-effector-link" });
  private readonly toolPicker = el("select", { id: "tool-picker", "aria-label": "Tool link" });
  private readonly toolRow = el(
    "label",
    { class: "tool-choice", hidden: "" },
    el("span", {}, "Tool link"),
    this.toolPicker,
  );
  private readonly jointList = el("div", { class: "joints", id: "joints" });
  private readonly homeButton = el("button", { type: "button", class: "quiet" }, "Home position");
  private readonly rows = new Map<string, SliderRow>();
  private readonly brand: HTMLElement;
  private readonly pickers: HTMLElement;
  private readonly root: HTMLElement;
  /** The last element of the "top" slot: the next one goes after it. */
  private topEnd: HTMLElement;
  private jointsLocked = false;
  private robots: RobotEntry[] = [];
  private worlds: WorldEntry[] = [];

  constructor(root: HTMLElement, private readonly actions: PanelActions) {
    this.root = root;
    this.brand = el("header", { class: "brand" }, el("h1", {}, "robotrial"), this.status);
    this.pickers = el(
      "section",
      { class: "pickers" },
      el("label", {}, el("span", {}, "Robot"), this.robotPicker),
      el("label", {}, el("span", {}, "Place"), this.worldPicker),
    );
    this.topEnd = this.pickers;
    root.append(
      this.brand,
      this.pickers,
      el(
        "section",
        {},
        this.effectorTitle,
        this.effectorHint,
        this.toolRow,
        this.effector,
      ),
      el(
        "section",
        { class: "joint-section" },
        el("div", { class: "section-head" }, el("h2", {}, "Joints"), this.homeButton),
        this.jointList,
      ),
    );
    this.robotPicker.addEventListener("change", () => {
      const robot = this.robots.find((r) => r.name === this.robotPicker.value);
      if (robot) this.actions.pick(robot.name, this.worldFor(robot));
    });
    this.worldPicker.addEventListener("change", () => {
      this.actions.pick(this.robotPicker.value, this.worldPicker.value);
    });
    this.homeButton.addEventListener("click", () => this.actions.home());
    this.toolPicker.addEventListener("change", () => this.actions.chooseTool(this.toolPicker.value));
    this.setEndEffector(null);
  }

  /** Add `section` to the panel at `slot`; sections in one slot keep the order they
   * were mounted in. */
  mount(section: HTMLElement, slot: Slot = "end"): void {
    if (slot === "header") {
      this.brand.append(section);
    } else if (slot === "top") {
      this.topEnd.after(section);
      this.topEnd = section;
    } else {
      this.root.append(section);
    }
  }

  /** Block the joint sliders (the robot is set or moving) or free them again. */
  lockJoints(locked: boolean): void {
    this.jointsLocked = locked;
    for (const row of this.rows.values()) row.input.disabled = locked;
    this.homeButton.disabled = locked;
  }

  /** The built-in robots and worlds to choose from. */
  setCatalog(robots: RobotEntry[], worlds: WorldEntry[]): void {
    this.robots = robots;
    this.worlds = worlds;
    this.robotPicker.replaceChildren(
      ...robots.map((r) => el("option", { value: r.name }, robotTitle(r))),
    );
  }

  /** Show `robot` in `world` as chosen; the world list keeps to places that suit the robot. */
  setSelection(robot: string, world: string): void {
    this.robotPicker.value = robot;
    const kind = this.robots.find((r) => r.name === robot)?.kind;
    const suitable = this.worlds.filter((w) => w.kind === kind || w.name === world);
    this.worldPicker.replaceChildren(
      ...suitable.map((w) =>
        el("option", { value: w.name, title: w.description }, humanize(w.name)),
      ),
    );
    this.worldPicker.value = world;
  }

  /** One slider per driven joint, grouped (arm, gripper, other), at `values`. */
  setJoints(joints: ActuatedJoint[], values: number[]): void {
    this.rows.clear();
    const groups = new Map<string, ActuatedJoint[]>();
    for (const j of joints) groups.set(j.group, [...(groups.get(j.group) ?? []), j]);
    const order = [...groups.keys()].sort((a, b) => rank(a) - rank(b));
    const blocks = order.map((group) => {
      const rows = groups.get(group)!.map((j) => this.slider(j, values[joints.indexOf(j)]));
      if (order.length === 1) return el("div", { class: "group" }, ...rows);
      const title = GROUP_TITLES[group] ?? humanize(group);
      if (group !== "arm" && group !== "gripper") {
        return el("details", { class: "group" }, el("summary", {}, title), ...rows);
      }
      return el("div", { class: "group" }, el("h3", {}, title), ...rows);
    });
    const none = el("p", { class: "hint" }, "This robot has no moving joints.");
    this.jointList.replaceChildren(...(joints.length ? blocks : [none]));
    this.homeButton.hidden = joints.length === 0;
  }

  /** Move the sliders to new joint values (rad or m) without reporting them back. */
  showJointValues(values: Record<string, number>): void {
    for (const [name, value] of Object.entries(values)) {
      const row = this.rows.get(name);
      if (!row) continue;
      row.input.value = String(value);
      row.output.value = formatJoint(row.joint, value);
    }
  }

  /** Name what the position read-out shows: the tool link (of a hand, or for a robot
   * without an arm the link its description names), as the description spells it; with
   * `tools`, the links the user may pick instead. */
  describeEndEffector(link: string, hand: boolean, tools: string[] = []): void {
    this.effectorTitle.textContent = hand ? "Hand position" : "Position";
    this.effectorHint.textContent = link
      ? `of ${link}${hand ? " (the tool link)" : ""}, from the robot's base`
      : "from the robot's base";
    this.toolRow.hidden = tools.length < 2;
    this.toolPicker.replaceChildren(...tools.map((t) => el("option", { value: t }, t)));
    this.toolPicker.value = link;
  }

  /** The end-effector position (m) or null while nothing is loaded. */
  setEndEffector(xyz: Vec3 | null): void {
    const cells = ["x", "y", "z"].flatMap((axis, i) => [
      el("dt", {}, axis),
      el("dd", { "data-axis": axis }, xyz ? `${(xyz[i] * 100).toFixed(1)} cm` : "–"),
    ]);
    this.effector.replaceChildren(...cells);
  }

  setStatus(text: string, status: Status): void {
    this.status.textContent = text;
    this.status.dataset.status = status;
    this.robotPicker.disabled = status === "loading";
    this.worldPicker.disabled = status === "loading";
    this.toolPicker.disabled = status === "loading";
  }

  private worldFor(robot: RobotEntry): string {
    const current = this.worlds.find((w) => w.name === this.worldPicker.value);
    return current && current.kind === robot.kind ? current.name : robot.world;
  }

  private slider(joint: ActuatedJoint, value: number): HTMLElement {
    const id = `joint-${joint.name}`;
    const input = el("input", {
      id,
      type: "range",
      min: String(joint.lower),
      max: String(joint.upper),
      step: "any",
      value: String(value),
      "data-joint": joint.name,
    });
    input.disabled = this.jointsLocked;
    const output = el("output", { for: id }, formatJoint(joint, value));
    input.addEventListener("input", () => {
      const v = Number(input.value);
      output.value = formatJoint(joint, v);
      this.actions.moveJoint(joint.name, v);
    });
    this.rows.set(joint.name, { joint, input, output });
    return el(
      "div",
      { class: "slider" },
      el("label", { for: id, title: joint.name }, humanize(joint.name)),
      output,
      input,
    );
  }
}

function rank(group: string): number {
  const order = ["arm", "gripper"];
  const i = order.indexOf(group);
  return i >= 0 ? i : group === "other" ? 99 : 50;
}

/** Degrees for turning joints, centimetres for sliding ones. */
export function formatJoint(joint: ActuatedJoint, value: number): string {
  return joint.type === "prismatic"
    ? `${(value * 100).toFixed(1)} cm`
    : `${Math.round((value * 180) / Math.PI)}°`;
}
