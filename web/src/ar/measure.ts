// AR measuring, like a phone's measure app. Once the robot is placed, two taps on real
// surfaces (hit-test results) give a line and its length, shown live while the second
// end is aimed. The user says what it is, a doorway (its width) or a counter or table
// edge (its length and its height above the floor), and it joins the home drawn in
// My home, laid out from where the robot stands: the robot placed in AR is the robot at
// its start in the home, facing the plan's +x axis.

import {
  BufferGeometry,
  CanvasTexture,
  Float32BufferAttribute,
  Group,
  Line,
  LineBasicMaterial,
  Matrix4,
  Mesh,
  MeshBasicMaterial,
  Quaternion,
  SphereGeometry,
  Sprite,
  SpriteMaterial,
  Vector3,
} from "three";
import {
  type Doorway,
  type Furniture,
  type Home,
  PRESETS,
  type XY,
  addMeasured,
  round,
  spawnOf,
} from "../home/model";
import { WORDS as HOME_WORDS } from "../home/words";
import type { Vec3 } from "../types";
import { el } from "../ui/dom";
import type { ArPlacement } from "./ar";
import { MEASURE_WORDS as W } from "./words";

/** "off", aiming at the first or the second end, or both ends taken and a choice due. */
export type MeasureMode = "off" | "first" | "second" | "choose";

export interface MeasureState {
  mode: MeasureMode;
  /** The ends taken so far, in the session's `local` space (m). */
  points: Vec3[];
  /** Where the centre of the view meets a surface now, or null. */
  aim: Vec3 | null;
  /** The line's length (m): to the aim while the second end is aimed, then between the ends. */
  length: number | null;
  /** The last sentence shown, and whether it reports a refusal. */
  message: string;
  refused: boolean;
}

/** Change the home drawn in My home (the editor keeps it, undoably). */
export type HomeEdit = (next: (home: Home) => Home) => void;

export type MeasuredKind = "doorway" | "counter" | "table";

/** Shorter than this (m), two taps are the same spot. */
export const LEAST_LENGTH = 0.01;
/** A counter or table edge lies at least this high (m) above the floor. */
export const LEAST_HEIGHT = 0.05;
const LINE_COLOR = 0xf5a623;

/** Where `p` (the session's `local` space) lies in the home: [x, y] on the plan and its
 * height above the floor the robot stands on. The robot placed in AR stands at `start`,
 * facing the plan's +x axis (its base frame is the plan's frame moved to `start`). */
export function toHome(p: Vec3, placement: ArPlacement, start: XY): Vec3 {
  const base = new Matrix4().compose(
    new Vector3(...placement.xyz),
    new Quaternion(...placement.quat),
    new Vector3(1, 1, 1),
  );
  const r = new Vector3(...p).applyMatrix4(base.invert());
  return [start[0] + r.x, start[1] + r.y, r.z];
}

/** Where the robot starts in `home`: its start, the middle of its first room, or the origin. */
export function homeStart(home: Home): XY {
  if (home.rooms.length) return spawnOf(home);
  return home.spawn ?? [0, 0];
}

/** A doorway between two measured ends (home coordinates): as wide as they are apart
 * on the plan, centred between them. */
export function measuredDoorway(a: Vec3, b: Vec3, name: string): Doorway {
  return {
    name,
    at: [round((a[0] + b[0]) / 2), round((a[1] + b[1]) / 2)],
    width: round(Math.hypot(b[0] - a[0], b[1] - a[1])),
  };
}

/** A box of furniture whose front edge runs from `a` to `b` (home coordinates, z the
 * height): as long as the edge, as high as its middle, as deep as the preset, reaching
 * away from `eye` (where the user stood). Boxes in the plan are axis-aligned, so the
 * edge is taken along the plan's axis nearest to it. */
export function measuredSurface(a: Vec3, b: Vec3, eye: XY, kind: "counter" | "table"): Furniture {
  const preset = PRESETS[kind];
  const depth = preset.size[1];
  const length = Math.hypot(b[0] - a[0], b[1] - a[1]);
  const mid: XY = [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2];
  const alongX = Math.abs(b[0] - a[0]) >= Math.abs(b[1] - a[1]);
  const axis = alongX ? 1 : 0;
  const away = mid[axis] >= eye[axis] ? 1 : -1;
  const at: XY = [...mid];
  at[axis] += (away * depth) / 2;
  return {
    name: preset.name,
    shape: "box",
    at: [round(at[0]), round(at[1])],
    size: alongX ? [round(length), depth] : [depth, round(length)],
    height: round((a[2] + b[2]) / 2),
  };
}

/** A text label that faces the viewer: the length at the line's middle. */
class LengthLabel {
  readonly sprite: Sprite;
  private readonly canvas = el("canvas", { width: "256", height: "64" });
  private readonly texture = new CanvasTexture(this.canvas);
  private text = "";

  constructor() {
    this.sprite = new Sprite(new SpriteMaterial({ map: this.texture, depthTest: false }));
    this.sprite.scale.set(0.2, 0.05, 1);
    this.sprite.renderOrder = 2;
  }

  show(text: string): void {
    if (text === this.text) return;
    this.text = text;
    const context = this.canvas.getContext("2d");
    if (!context) return;
    context.clearRect(0, 0, 256, 64);
    context.fillStyle = "rgba(255, 255, 255, 0.9)";
    context.fillRect(0, 0, 256, 64);
    context.fillStyle = "#1d2330";
    context.font = "bold 40px sans-serif";
    context.textAlign = "center";
    context.textBaseline = "middle";
    context.fillText(text, 128, 34);
    this.texture.needsUpdate = true;
  }
}

/** The Measure mode of an AR session: its buttons (for the overlay bar), its line and
 * label (for the overlay scene), and what a tap does while it is on. */
export class Measure {
  /** The line, the ends and the label, drawn over the camera image. */
  readonly group = new Group();
  /** The buttons and the length read-out, for the AR overlay bar. */
  readonly bar: HTMLElement;
  private mode: MeasureMode = "off";
  private points: Vector3[] = [];
  private aim: Vector3 | null = null;
  private eye = new Vector3();
  private message = "";
  private refused = false;
  private readonly line: Line;
  private readonly ends: Mesh[];
  private readonly label = new LengthLabel();
  private readonly toggle = el("button", { type: "button", id: "ar-measure" }, W.start);
  private readonly length = el("strong", { id: "ar-measure-length", hidden: "" });
  private readonly choices: HTMLButtonElement[];

  /** `placement()`: where the robot stands; `editHome`: changes the home in My home;
   * `say`: puts a sentence in the overlay bar. */
  constructor(
    private readonly placement: () => ArPlacement | null,
    private readonly editHome: HomeEdit | null,
    private readonly say: (text: string) => void,
  ) {
    const geometry = new BufferGeometry();
    geometry.setAttribute("position", new Float32BufferAttribute(new Float32Array(6), 3));
    this.line = new Line(geometry, new LineBasicMaterial({ color: LINE_COLOR, depthTest: false }));
    this.line.renderOrder = 1;
    const dot = new SphereGeometry(0.012, 12, 8);
    const material = new MeshBasicMaterial({ color: LINE_COLOR, depthTest: false });
    this.ends = [new Mesh(dot, material), new Mesh(dot, material)];
    this.group.add(this.line, ...this.ends, this.label.sprite);
    this.group.name = "ar-measure";
    this.group.visible = false;

    this.toggle.addEventListener("click", () => (this.mode === "off" ? this.start() : this.stop()));
    const choice = (id: string, label: string, kind: MeasuredKind | null): HTMLButtonElement => {
      const button = el("button", { type: "button", id, hidden: "" }, label);
      button.addEventListener("click", () => (kind ? this.choose(kind) : this.again()));
      return button;
    };
    this.choices = [
      choice("ar-measure-door", W.doorway, "doorway"),
      choice("ar-measure-counter", W.counter, "counter"),
      choice("ar-measure-table", W.table, "table"),
      choice("ar-measure-again", W.discard, null),
    ];
    this.bar = el("span", { class: "ar-measure", id: "ar-measure-bar", hidden: "" });
    this.bar.append(this.length, ...this.choices, this.toggle);
  }

  /** True while a tap takes an end (the reticle shows where). */
  get aiming(): boolean {
    return this.mode === "first" || this.mode === "second";
  }

  /** True while Measure is on: taps belong to it, not to placing the robot. */
  get active(): boolean {
    return this.mode !== "off";
  }

  /** Offer Measure (once the robot is placed) or take it away (a new session). */
  offer(placed: boolean): void {
    this.bar.hidden = !placed;
    if (!placed) this.stop();
  }

  state(): MeasureState {
    return {
      mode: this.mode,
      points: this.points.map((p) => [p.x, p.y, p.z]),
      aim: this.aim ? [this.aim.x, this.aim.y, this.aim.z] : null,
      length: this.currentLength(),
      message: this.message,
      refused: this.refused,
    };
  }

  start(): void {
    if (!this.placement()) {
      this.tell(W.placeFirst, true);
      return;
    }
    this.points = [];
    this.set("first");
    this.tell(W.first, false);
  }

  stop(): void {
    this.points = [];
    this.aim = null;
    this.set("off");
  }

  /** Each frame: where the view's centre meets a surface (a pose in the session's
   * space, or null) and where the viewer stands. */
  frame(hit: Matrix4 | null, eye: Vector3): void {
    this.aim = hit ? new Vector3().setFromMatrixPosition(hit) : null;
    this.eye.copy(eye);
    // A surface is in view again after "no surface": say what the next tap takes.
    if (this.aim && this.message === W.noHit) {
      this.tell(this.mode === "first" ? W.first : W.second, false);
    }
    this.draw();
  }

  /** A tap (the session's `select`): the first end, or the second, where the view aims. */
  tap(): void {
    if (!this.aiming) return;
    if (!this.aim) {
      this.tell(W.noHit, true);
      return;
    }
    if (this.mode === "first") {
      this.points = [this.aim.clone()];
      this.set("second");
      this.tell(W.second, false);
      return;
    }
    const length = this.points[0].distanceTo(this.aim);
    if (length < LEAST_LENGTH) {
      this.tell(W.tooShort(length, LEAST_LENGTH), true);
      return;
    }
    this.points = [this.points[0], this.aim.clone()];
    this.set("choose");
    this.tell(W.choose(length), false);
  }

  /** The user said what the line is: it joins the home, then the next measure starts. */
  choose(kind: MeasuredKind): void {
    const placement = this.placement();
    if (this.mode !== "choose" || !placement || !this.editHome) return;
    const [pa, pb] = this.points;
    const eyeLocal: Vec3 = [this.eye.x, this.eye.y, this.eye.z];
    let said = "";
    let refused = false;
    this.editHome((home) => {
      const start = homeStart(home);
      const a = toHome([pa.x, pa.y, pa.z], placement, start);
      const b = toHome([pb.x, pb.y, pb.z], placement, start);
      if (kind === "doorway") {
        const door = measuredDoorway(a, b, HOME_WORDS.doorName(home.doorways.length + 1));
        const added = addMeasured(home, { doorway: door });
        said = added.room
          ? W.doorOnWall(added.name, door.width, added.room)
          : W.doorListed(added.name, door.width);
        return added.home;
      }
      const eye = toHome(eyeLocal, placement, start);
      const box = measuredSurface(a, b, [eye[0], eye[1]], kind);
      if (box.height < LEAST_HEIGHT) {
        said = W.onFloor(box.height);
        refused = true;
        return home;
      }
      const added = addMeasured(home, { furniture: box });
      said = W.furniture(added.name, Math.hypot(b[0] - a[0], b[1] - a[1]), box.height);
      return added.home;
    });
    this.points = [];
    this.set("first");
    this.tell(said, refused);
  }

  /** Drop both ends and start over. */
  again(): void {
    this.points = [];
    this.set("first");
    this.tell(W.first, false);
  }

  private currentLength(): number | null {
    if (this.mode === "second" && this.aim) return this.points[0].distanceTo(this.aim);
    if (this.points.length === 2) return this.points[0].distanceTo(this.points[1]);
    return null;
  }

  private tell(text: string, refused: boolean): void {
    this.message = text;
    this.refused = refused;
    this.say(text);
  }

  private set(mode: MeasureMode): void {
    this.mode = mode;
    this.toggle.textContent = mode === "off" ? W.start : W.stop;
    for (const button of this.choices) button.hidden = mode !== "choose";
    this.draw();
  }

  /** The line from the first end to the second (or to the aim), its ends and its length. */
  private draw(): void {
    const a = this.points[0];
    const b = this.points[1] ?? (this.mode === "second" ? this.aim : null);
    const length = this.currentLength();
    this.length.hidden = length === null;
    this.length.textContent = length === null ? "" : W.length(length);
    this.group.visible = this.mode !== "off" && !!a;
    if (!a) return;
    this.ends[0].position.copy(a);
    this.ends[1].visible = !!b;
    this.line.visible = this.label.sprite.visible = !!b;
    if (!b || length === null) return;
    this.ends[1].position.copy(b);
    const position = this.line.geometry.getAttribute("position") as Float32BufferAttribute;
    position.setXYZ(0, a.x, a.y, a.z);
    position.setXYZ(1, b.x, b.y, b.z);
    position.needsUpdate = true;
    this.line.geometry.computeBoundingSphere();
    this.label.sprite.position.copy(a).add(b).multiplyScalar(0.5).add(new Vector3(0, 0.04, 0));
    this.label.show(W.length(length));
  }
}
