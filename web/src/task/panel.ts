// The task's part of the side panel: the g2rViewer buttons (Set Robot, Add obstacles,
// Reset Robot, Move Robot!), the planner's message, numeric editing of the obstacles,
// the object and the goal, the scene file, and the rosbridge connection. Like the rest
// of the panel it only shows things and reports what the user did.

import type { ConnectionState } from "../ros/connection";
import { el } from "../ui/dom";
import type { Vec3 } from "../types";
import { quatYaw, type TaskBox, yawQuat } from "./arrangement";
import type { GizmoMode, Pick } from "./editor";

export interface TaskActions {
  setRobot(): void;
  addObstacle(): void;
  resetRobot(): void;
  moveRobot(): void;
  editObstacle(box: TaskBox): void;
  removeObstacle(id: string): void;
  carryObject(on: boolean): void;
  editObject(box: TaskBox): void;
  objectToHand(): void;
  editGoal(goal: Vec3): void;
  select(pick: Pick | null): void;
  gizmoMode(mode: GizmoMode): void;
  saveScene(): void;
  loadScene(file: File): void;
  connect(url: string): void;
}

/** Where the task stands: what the buttons allow. */
export type Phase = "editing" | "set" | "planning" | "moving" | "done";
export type MessageKind = "info" | "ok" | "error";

const BOX_FIELDS = [
  ["x", "x", "cm"],
  ["y", "y", "cm"],
  ["z", "z", "cm"],
  ["width", "Width", "cm"],
  ["depth", "Depth", "cm"],
  ["height", "Height", "cm"],
  ["turn", "Turn", "°"],
] as const;
type BoxField = (typeof BOX_FIELDS)[number][0];

const STATUS_TEXT: Record<ConnectionState["status"], string> = {
  connected: "Connected",
  connecting: "Connecting…",
  disconnected: "Not connected",
};

export class TaskPanel {
  /** The buttons and message: mounted under the pickers (slot "top"). */
  readonly main: HTMLElement;
  /** Obstacles, object, goal, scene file, connection: further down. */
  readonly details: HTMLElement;
  /** The connection indicator: mounted in the panel's header (slot "header"). */
  readonly indicator: HTMLElement;

  private readonly setButton = button(
    "set-robot",
    "Set Robot",
    "Fix the start posture and the goal",
  );
  private readonly addButton = button(
    "add-obstacle",
    "Add obstacles",
    "Place a box over a piece of furniture",
  );
  private readonly resetButton = button(
    "reset-robot",
    "Reset Robot",
    "Back to the start, editable again",
  );
  private readonly moveButton = button(
    "move-robot",
    "Move Robot!",
    "Plan a path and move the robot",
    "primary",
  );
  private readonly message = el("p", {
    id: "task-message",
    class: "task-message",
    role: "status",
    "aria-live": "polite",
  });
  private readonly obstacleList = el("div", { id: "obstacles", class: "box-list" });
  private readonly obstacleCount = el("span", { class: "count" });
  private readonly carry = el("input", { type: "checkbox", id: "carry-object" });
  private readonly objectFields: HTMLElement;
  private readonly objectInputs = new Map<BoxField, HTMLInputElement>();
  private readonly toHand = el(
    "button",
    { type: "button", class: "quiet", id: "object-to-hand" },
    "Put in the hand",
  );
  private readonly goalInputs = new Map<string, HTMLInputElement>();
  private readonly modeButtons = new Map<GizmoMode, HTMLButtonElement>();
  private readonly urlInput = el("input", {
    id: "rosbridge-url",
    type: "url",
    spellcheck: "false",
    "aria-label": "rosbridge address",
  });
  private readonly connectionText = el("p", { class: "hint", id: "connection-detail" });
  private readonly rows = new Map<string, Map<BoxField, HTMLInputElement>>();
  private readonly fileInput = el("input", {
    type: "file",
    accept: ".json,application/json",
    id: "scene-file",
    hidden: "",
  });
  private editable = true;

  constructor(private readonly actions: TaskActions) {
    this.setButton.addEventListener("click", () => actions.setRobot());
    this.addButton.addEventListener("click", () => actions.addObstacle());
    this.resetButton.addEventListener("click", () => actions.resetRobot());
    this.moveButton.addEventListener("click", () => actions.moveRobot());
    this.main = el(
      "section",
      { class: "task", "aria-label": "Task" },
      el(
        "div",
        { class: "task-buttons" },
        this.setButton,
        this.addButton,
        this.resetButton,
        this.moveButton,
      ),
      this.message,
    );

    const modes = el("div", {
      class: "segmented",
      id: "gizmo-mode",
      role: "group",
      "aria-label": "What dragging does",
    });
    for (const [mode, label] of [
      ["translate", "Move"],
      ["rotate", "Turn"],
      ["scale", "Resize"],
    ] as const) {
      const b = el("button", { type: "button", "data-mode": mode }, label);
      b.addEventListener("click", () => {
        this.showMode(mode);
        actions.gizmoMode(mode);
      });
      this.modeButtons.set(mode, b);
      modes.append(b);
    }
    this.showMode("translate");

    this.carry.addEventListener("change", () => actions.carryObject(this.carry.checked));
    this.toHand.addEventListener("click", () => actions.objectToHand());
    this.objectFields = this.boxFields(
      this.objectInputs,
      (box) => actions.editObject(box),
      "object",
    );
    const goalRow = el("div", { class: "fields three", id: "goal" });
    for (const axis of ["x", "y", "z"]) {
      const input = numberInput(`goal-${axis}`, "1");
      input.dataset.field = axis;
      input.addEventListener("change", () => actions.editGoal(this.goalValue()));
      this.goalInputs.set(axis, input);
      goalRow.append(el("label", {}, el("span", {}, `${axis} cm`), input));
    }

    const save = el("button", { type: "button", class: "quiet", id: "save-scene" }, "Save scene");
    const load = el("button", { type: "button", class: "quiet", id: "load-scene" }, "Load…");
    save.addEventListener("click", () => actions.saveScene());
    load.addEventListener("click", () => this.fileInput.click());
    this.fileInput.addEventListener("change", () => {
      const file = this.fileInput.files?.[0];
      if (file) actions.loadScene(file);
      this.fileInput.value = "";
    });

    const connect = el(
      "button",
      { type: "button", class: "quiet", id: "rosbridge-connect" },
      "Connect",
    );
    const submit = () => actions.connect(this.urlInput.value);
    connect.addEventListener("click", submit);
    this.urlInput.addEventListener("keydown", (e) => {
      if (e.key === "Enter") submit();
    });
    this.indicator = el(
      "p",
      { class: "connection", id: "connection", "data-status": "disconnected", title: "" },
      "Not connected",
    );

    this.details = el(
      "div",
      { class: "task-details" },
      el(
        "details",
        { open: "" },
        el("summary", {}, "Obstacles ", this.obstacleCount),
        el("p", { class: "hint" }, "Click a box in the view to drag it; boxes stay on the table."),
        modes,
        this.obstacleList,
      ),
      el(
        "details",
        {},
        el("summary", {}, "Object to carry"),
        el("label", { class: "check" }, this.carry, el("span", {}, "The robot carries an object")),
        this.objectFields,
        this.toHand,
      ),
      el("details", {}, el("summary", {}, "Goal for the hand"), goalRow),
      el(
        "details",
        {},
        el("summary", {}, "Scene file"),
        el("div", { class: "row" }, save, load),
        this.fileInput,
      ),
      el(
        "details",
        {},
        el("summary", {}, "Connection"),
        el(
          "p",
          { class: "hint" },
          "The planner is reached through rosbridge. Point the page at another ROS system here.",
        ),
        el("div", { class: "row" }, this.urlInput, connect),
        this.connectionText,
      ),
    );
    this.showObstacles([]);
  }

  /** Enable the buttons and fields that fit `phase`; `canPlan`: a planner is reachable. */
  setPhase(phase: Phase, canPlan: boolean): void {
    const busy = phase === "planning" || phase === "moving";
    this.editable = phase === "editing";
    this.setButton.disabled = phase !== "editing";
    this.addButton.disabled = phase !== "editing";
    this.resetButton.disabled = phase === "editing" || busy;
    this.moveButton.disabled = busy || !canPlan;
    this.moveButton.title = canPlan
      ? "Plan a path and move the robot"
      : "Needs a planner: see Connection below";
    this.applyEditable();
    this.main.dataset.phase = phase;
  }

  /** Show the task's sections (an arm is on screen) or hide them. */
  setVisible(visible: boolean): void {
    this.main.hidden = !visible;
    this.details.hidden = !visible;
  }

  say(text: string, kind: MessageKind = "info"): void {
    this.message.textContent = text;
    this.message.dataset.kind = kind;
  }

  showObstacles(boxes: TaskBox[]): void {
    this.obstacleCount.textContent = boxes.length ? `(${boxes.length})` : "";
    const current = new Set(boxes.map((b) => b.id));
    for (const id of [...this.rows.keys()]) if (!current.has(id)) this.rows.delete(id);
    const rows = boxes.map((box, i) => {
      let inputs = this.rows.get(box.id);
      let row = this.obstacleList.querySelector<HTMLElement>(
        `[data-obstacle="${CSS.escape(box.id)}"]`,
      );
      if (!inputs || !row) {
        inputs = new Map();
        this.rows.set(box.id, inputs);
        const remove = el(
          "button",
          {
            type: "button",
            class: "quiet danger",
            "data-action": "delete",
            "aria-label": `Delete obstacle ${i + 1}`,
          },
          "Delete",
        );
        remove.addEventListener("click", () => this.actions.removeObstacle(box.id));
        const select = el(
          "button",
          { type: "button", class: "link", "data-action": "select" },
          `Obstacle ${i + 1}`,
        );
        select.addEventListener("click", () =>
          this.actions.select({ kind: "obstacle", id: box.id }),
        );
        row = el(
          "div",
          { class: "box-row", "data-obstacle": box.id },
          el("div", { class: "row" }, select, remove),
          this.boxFields(inputs, (b) => this.actions.editObstacle({ ...b, id: box.id }), box.id),
        );
      }
      fill(inputs, box);
      return row;
    });
    const empty = el("p", { class: "hint" }, "No obstacles yet: press Add obstacles.");
    this.obstacleList.replaceChildren(...(rows.length ? rows : [empty]));
    this.applyEditable();
  }

  /** Highlight the picked row. */
  showSelection(pick: Pick | null): void {
    for (const row of this.obstacleList.querySelectorAll<HTMLElement>(".box-row")) {
      row.classList.toggle(
        "selected",
        pick?.kind === "obstacle" && pick.id === row.dataset.obstacle,
      );
    }
  }

  showObject(box: TaskBox | null): void {
    this.carry.checked = box !== null;
    this.objectFields.hidden = box === null;
    this.toHand.hidden = box === null;
    if (box) fill(this.objectInputs, box);
  }

  showGoal(goal: Vec3): void {
    ["x", "y", "z"].forEach((axis, i) => {
      this.goalInputs.get(axis)!.value = (goal[i] * 100).toFixed(1);
    });
  }

  showConnection(state: ConnectionState): void {
    this.indicator.dataset.status = state.status;
    this.indicator.textContent = STATUS_TEXT[state.status];
    this.indicator.title = state.url;
    if (document.activeElement !== this.urlInput) this.urlInput.value = state.url;
    let detail = state.status === "connected" ? `Connected to ${state.url}` : "";
    if (state.status !== "connected" && state.error) detail = `${state.error}.`;
    if (state.retryAt) {
      const seconds = Math.max(0, Math.round((state.retryAt - Date.now()) / 100) / 10);
      detail += ` Trying again in ${seconds} s.`;
    }
    this.connectionText.textContent = detail.trim();
  }

  /** Fields and buttons that change the arrangement work only while editing. */
  private applyEditable(): void {
    const editing = this.details.querySelectorAll<HTMLInputElement | HTMLButtonElement>(
      "#obstacles input, #obstacles button, #carry-object, #object-fields input, " +
        "#object-to-hand, #goal input, #gizmo-mode button, #load-scene",
    );
    for (const control of editing) control.disabled = !this.editable;
  }

  private showMode(mode: GizmoMode): void {
    for (const [m, b] of this.modeButtons) b.setAttribute("aria-pressed", String(m === mode));
  }

  private goalValue(): Vec3 {
    return ["x", "y", "z"].map((a) => Number(this.goalInputs.get(a)!.value) / 100) as Vec3;
  }

  private boxFields(
    inputs: Map<BoxField, HTMLInputElement>,
    edit: (box: TaskBox) => void,
    key: string,
  ): HTMLElement {
    const grid = el("div", { class: "fields three", id: `${key}-fields` });
    for (const [field, label, unit] of BOX_FIELDS) {
      const input = numberInput(`${key}-${field}`, field === "turn" ? "5" : "0.5");
      input.dataset.field = field;
      input.addEventListener("change", () => edit(read(inputs)));
      inputs.set(field, input);
      grid.append(el("label", {}, el("span", {}, `${label} ${unit}`), input));
    }
    return grid;
  }
}

function button(id: string, label: string, title: string, kind = ""): HTMLButtonElement {
  return el("button", { type: "button", id, title, class: `task-button ${kind}`.trim() }, label);
}

function numberInput(id: string, step: string): HTMLInputElement {
  return el("input", { type: "number", id, step, inputmode: "decimal" });
}

function fill(inputs: Map<BoxField, HTMLInputElement>, box: TaskBox): void {
  const cm = (v: number) => (v * 100).toFixed(1);
  const values: Record<BoxField, string> = {
    x: cm(box.position[0]),
    y: cm(box.position[1]),
    z: cm(box.position[2]),
    width: cm(box.size[0]),
    depth: cm(box.size[1]),
    height: cm(box.size[2]),
    turn: String(Math.round((quatYaw(box.quaternion) * 180) / Math.PI)),
  };
  for (const [field, input] of inputs) {
    if (document.activeElement !== input) input.value = values[field];
  }
}

function read(inputs: Map<BoxField, HTMLInputElement>): TaskBox {
  const v = (f: BoxField) => Number(inputs.get(f)!.value);
  return {
    id: "",
    position: [v("x") / 100, v("y") / 100, v("z") / 100],
    size: [v("width") / 100, v("depth") / 100, v("height") / 100],
    quaternion: yawQuat((v("turn") * Math.PI) / 180),
  };
}
