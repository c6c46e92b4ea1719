// "My home": the panel section and the top-down editor it opens (an SVG plan on the
// left, every number in a list on the right). The drawing is kept in localStorage after
// every change; every change can be undone (buttons, Ctrl+Z, Ctrl+Shift+Z); a bad
// number or a bad file leaves the drawing as it was and says why.

import { errorText, type WorldEntry } from "../api";
import { pageToken } from "../ros/connection";
import { el } from "../ui/dom";
import "./home.css";
import {
  type Drawing,
  type Home,
  PRESETS,
  type XY,
  checkShape,
  edgeLength,
  emptyHome,
  fromYaml,
  nearestEdge,
  problems,
  round,
  setEdgeLength,
  snap,
  spawnOf,
  toYaml,
  walls,
} from "./model";
import { type Gray, detectRooms, parseMapYaml, parsePgm } from "./floorplan";
import { VerdictView } from "./verdict";
import { WORDS } from "./words";

export const STORAGE_KEY = "robotrial.home";
export const WORLDS_URL = "/api/worlds";
const SVG = "http://www.w3.org/2000/svg";
/** How close (m) a click must be to a wall to put a doorway in it. */
const DOOR_PICK = 0.4;
/** How close (m) a click must be to a room's first corner to close the room. */
const CLOSE_PICK = 0.15;

type Tool = keyof typeof WORDS.tools;
type Status = "ready" | "error" | "loading";

function svg<K extends keyof SVGElementTagNameMap>(
  tag: K,
  attributes: Record<string, string | number> = {},
): SVGElementTagNameMap[K] {
  const node = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attributes)) node.setAttribute(k, String(v));
  return node;
}

/** Send a home's YAML to the server; resolves with its world entry. */
export async function sendWorld(yaml: string): Promise<WorldEntry> {
  const token = pageToken();
  const headers: Record<string, string> = { "Content-Type": "application/yaml" };
  if (token) headers.Authorization = `Bearer ${token}`;
  const response = await fetch(WORLDS_URL, { method: "POST", body: yaml, headers });
  if (!response.ok) {
    throw new Error((await errorText(WORLDS_URL, response)).replace(`${WORLDS_URL}: `, ""));
  }
  return (await response.json()) as WorldEntry;
}

/** A decoded image and its size in pixels. */
function loadImage(url: string, name: string): Promise<{ image: HTMLImageElement; size: XY }> {
  return new Promise((resolve, reject) => {
    const image = new Image();
    image.onload = () => resolve({ image, size: [image.naturalWidth, image.naturalHeight] });
    image.onerror = () => reject(new Error(WORDS.notImage(name)));
    image.src = url;
  });
}

/** A grey image as a PNG data URL (inverted when `negate`). */
function grayUrl(gray: Gray, negate: boolean): string {
  const canvas = el("canvas", { width: `${gray.width}`, height: `${gray.height}` });
  const context = canvas.getContext("2d");
  if (!context) throw new Error("no 2D canvas");
  const data = context.createImageData(gray.width, gray.height);
  gray.pixels.forEach((v, k) => {
    const g = negate ? 255 - v : v;
    data.data.set([g, g, g, 255], 4 * k);
  });
  context.putImageData(data, 0, 0);
  return canvas.toDataURL("image/png");
}

export class HomeSection {
  /** The panel section: the app mounts it (Panel.mount). */
  readonly section: HTMLElement;
  private readonly overlay: HTMLElement;
  private readonly plan = svg("g", { id: "home-plan", transform: "scale(1,-1)" });
  private readonly canvas = svg("svg", { id: "home-canvas", role: "img" });
  private readonly lists = el("div", { class: "home-lists", id: "home-lists" });
  private readonly problemList = el("ul", { class: "home-problems", id: "home-problems" });
  private readonly message = el("p", { class: "home-message", id: "home-message", role: "status" });
  private readonly hint = el("p", { class: "hint", id: "home-hint" });
  private readonly doorWidth = el("input", {
    id: "home-door-width",
    type: "text",
    inputmode: "decimal",
    value: "0.8",
  });
  private readonly preset = el("select", { id: "home-preset" });
  private readonly fileInput = el("input", { type: "file", id: "home-open", accept: ".yaml,.yml" });
  private readonly imageInput = el("input", {
    type: "file",
    id: "home-image",
    accept: "image/png,image/jpeg,.pgm,.yaml,.yml",
    multiple: "",
  });
  private readonly knownLength = el("input", { id: "home-known-length", type: "text", inputmode: "decimal" });
  /** The floor-plan image under the plan: its data URL, size in pixels, metres per pixel
   * and where its bottom-left corner lies (m). */
  private background: { url: string; width: number; height: number; mpp: number; origin?: XY } | null =
    null;
  private marks: XY[] = [];
  private readonly toolButtons = new Map<Tool, HTMLButtonElement>();
  private readonly buttons: Record<string, HTMLButtonElement> = {};
  private drawing: Drawing = { home: emptyHome(), draft: null };
  private undoStack: string[] = [];
  private redoStack: string[] = [];
  private tool: Tool = "room";
  private pointer: XY | null = null;
  /** "Check my home": the robot pickers, the progress and the verdict. */
  private readonly verdict = new VerdictView({
    yaml: () => this.yaml(),
    home: () => this.drawing.home,
    changed: () => this.drawPlan(),
  });

  /** `sent(entry)`: the app adds the world to its picker and shows the robot in it. */
  constructor(private readonly sent: (entry: WorldEntry) => Promise<void>) {
    const open = el("button", { type: "button", id: "home-open-editor" }, WORDS.open);
    this.section = el(
      "section",
      { class: "home", id: "home" },
      el("h2", {}, WORDS.title),
      el("p", { class: "hint" }, WORDS.hint),
      open,
    );
    open.addEventListener("click", () => this.show(true));
    this.overlay = this.buildOverlay();
    document.body.append(this.overlay);
    this.restore();
    this.setTool("room");
    this.render();
  }

  /** Change the home from outside the editor (AR measurements): one undoable change,
   * kept in localStorage and shown when the editor opens. */
  edit(next: (home: Home) => Home): void {
    this.change((d) => ({ ...d, home: next(d.home) }));
  }

  // --- building the editor -----------------------------------------------------------

  private button(id: string, label: string, action: () => void): HTMLButtonElement {
    const b = el("button", { type: "button", id }, label);
    b.addEventListener("click", action);
    this.buttons[id] = b;
    return b;
  }

  private buildOverlay(): HTMLElement {
    for (const [key, preset] of Object.entries(PRESETS)) {
      this.preset.append(el("option", { value: key }, preset.name));
    }
    const tools = el("div", { class: "home-tools", role: "toolbar" });
    for (const tool of Object.keys(WORDS.tools) as Tool[]) {
      const b = this.button(`home-tool-${tool}`, WORDS.tools[tool], () => this.setTool(tool));
      this.toolButtons.set(tool, b);
      tools.append(b);
    }
    const actions = el(
      "div",
      { class: "home-tools" },
      this.button("home-close-room", WORDS.closeRoom, () => this.closeRoom()),
      this.button("home-cancel-room", WORDS.cancelRoom, () => this.cancelRoom()),
      el("label", {}, WORDS.doorWidth, " ", this.doorWidth),
      el("label", {}, WORDS.preset, " ", this.preset),
      this.button("home-undo", WORDS.undo, () => this.undo()),
      this.button("home-redo", WORDS.redo, () => this.redo()),
      this.button("home-clear", WORDS.clear, () => this.change(() => ({ home: emptyHome(), draft: null }))),
      this.button("home-download", WORDS.download, () => this.download()),
      el("label", { class: "home-file" }, WORDS.openYaml, " ", this.fileInput),
      this.button("home-send", WORDS.send, () => void this.send()),
      this.verdict.controls,
      el("label", { class: "home-file" }, WORDS.background, " ", this.imageInput),
      el("label", {}, WORDS.knownLength, " ", this.knownLength),
      this.button("home-set-scale", WORDS.setScale, () => this.setScale()),
      this.button("home-find-rooms", WORDS.findRooms, () => void this.findRooms()),
      this.button("home-close", WORDS.close, () => this.show(false)),
    );
    this.canvas.append(this.plan);
    this.canvas.addEventListener("click", (e) => this.clicked(e));
    this.canvas.addEventListener("mousemove", (e) => {
      this.pointer = this.toPlan(e);
      if (this.drawing.draft) this.drawPlan();
    });
    this.fileInput.addEventListener("change", () => {
      const file = this.fileInput.files?.[0];
      if (file) void this.openFile(file);
    });
    this.imageInput.addEventListener("change", () => {
      const files = [...(this.imageInput.files ?? [])];
      if (files.length) void this.openImage(files);
    });
    document.addEventListener("keydown", (e) => this.key(e));
    return el(
      "div",
      { class: "home-editor", id: "home-editor", hidden: "" },
      el("h2", {}, WORDS.title),
      tools,
      actions,
      this.hint,
      this.message,
      el(
        "div",
        { class: "home-body" },
        el("div", { class: "home-drawing" }, this.canvas),
        el("div", { class: "home-side" }, this.verdict.section, this.problemList, this.lists),
      ),
    );
  }

  private show(open: boolean): void {
    this.overlay.hidden = !open;
    if (open) {
      this.render();
      void this.verdict.loadRobots();
    }
  }

  private setTool(tool: Tool): void {
    this.tool = tool;
    for (const [t, b] of this.toolButtons) b.setAttribute("aria-pressed", String(t === tool));
    this.hint.textContent = WORDS.toolHints[tool];
  }

  private key(e: KeyboardEvent): void {
    if (this.overlay.hidden || !(e.ctrlKey || e.metaKey)) return;
    const target = e.target as HTMLElement | null;
    if (target && (target.tagName === "INPUT" || target.tagName === "SELECT")) return;
    const k = e.key.toLowerCase();
    if (k === "z" && e.shiftKey) this.redo();
    else if (k === "z") this.undo();
    else if (k === "y") this.redo();
    else return;
    e.preventDefault();
  }

  // --- state, undo, storage ------------------------------------------------------------

  /** Apply a change: the old drawing goes on the undo stack, the new one is kept. */
  private change(next: (d: Drawing) => Drawing): void {
    const before = JSON.stringify(this.drawing);
    const after = next(structuredClone(this.drawing));
    if (JSON.stringify(after) === before) return;
    this.undoStack.push(before);
    this.redoStack = [];
    this.drawing = after;
    this.save();
    this.render();
  }

  private undo(): void {
    const last = this.undoStack.pop();
    if (last === undefined) return;
    this.redoStack.push(JSON.stringify(this.drawing));
    this.drawing = JSON.parse(last) as Drawing;
    this.save();
    this.render();
  }

  private redo(): void {
    const next = this.redoStack.pop();
    if (next === undefined) return;
    this.undoStack.push(JSON.stringify(this.drawing));
    this.drawing = JSON.parse(next) as Drawing;
    this.save();
    this.render();
  }

  private save(): void {
    localStorage.setItem(STORAGE_KEY, JSON.stringify(this.drawing));
  }

  private restore(): void {
    const image = localStorage.getItem(`${STORAGE_KEY}.image`);
    if (image) {
      try {
        this.background = JSON.parse(image) as typeof this.background;
      } catch {
        localStorage.removeItem(`${STORAGE_KEY}.image`);
      }
    }
    const kept = localStorage.getItem(STORAGE_KEY);
    if (!kept) return;
    try {
      const data = JSON.parse(kept) as { home?: unknown; draft?: unknown };
      const home = checkShape(data.home);
      if (typeof home === "string") throw new Error(home);
      const draft = Array.isArray(data.draft) ? (data.draft as XY[]) : null;
      this.drawing = { home, draft };
    } catch {
      localStorage.setItem(`${STORAGE_KEY}.broken`, kept);
      this.say(WORDS.restoreFailed, "error");
    }
  }

  private say(text: string, status: Status): void {
    this.message.textContent = text;
    this.message.dataset.status = status;
    this.message.setAttribute("role", status === "error" ? "alert" : "status");
  }

  // --- clicks on the plan -------------------------------------------------------------

  private toPlan(e: MouseEvent): XY {
    const ctm = this.plan.getScreenCTM();
    if (!ctm) return [0, 0];
    const p = new DOMPoint(e.clientX, e.clientY).matrixTransform(ctm.inverse());
    return [p.x, p.y];
  }

  private clicked(e: MouseEvent): void {
    const raw = this.toPlan(e);
    const p: XY = [round(snap(raw[0])), round(snap(raw[1]))];
    if (this.tool === "room") this.addCorner(p);
    else if (this.tool === "door") this.addDoor(raw);
    else if (this.tool === "furniture") {
      const preset = PRESETS[this.preset.value];
      this.change((d) => {
        const taken = new Set(d.home.furniture.map((f) => f.name));
        let name = preset.name;
        for (let i = 2; taken.has(name); i++) name = `${preset.name} ${i}`;
        d.home.furniture.push({ ...structuredClone(preset), name, at: p });
        return d;
      });
    } else if (this.tool === "object") {
      this.change((d) => {
        d.home.objects.push({ name: WORDS.objectName(d.home.objects.length + 1), at: p, size: 0.08 });
        return d;
      });
    } else if (this.tool === "scale") {
      this.marks = this.marks.length >= 2 ? [raw] : [...this.marks, raw];
      if (this.marks.length === 2) {
        const [a, b] = this.marks;
        this.say(WORDS.measured(Math.hypot(b[0] - a[0], b[1] - a[1])), "ready");
      }
      this.drawPlan();
    } else if (this.tool === "spawn") {
      this.change((d) => ({ ...d, home: { ...d.home, spawn: p } }));
    } else {
      const item = (e.target as Element | null)?.closest("[data-item]")?.getAttribute("data-item");
      if (item) document.getElementById(`row-${item}`)?.scrollIntoView({ block: "nearest" });
    }
  }

  private addCorner(p: XY): void {
    const draft = this.drawing.draft;
    if (draft && draft.length >= 3 && Math.hypot(p[0] - draft[0][0], p[1] - draft[0][1]) < CLOSE_PICK) {
      this.closeRoom();
      return;
    }
    const last = draft?.[draft.length - 1];
    if (last && last[0] === p[0] && last[1] === p[1]) return;
    this.change((d) => ({ ...d, draft: [...(d.draft ?? []), p] }));
  }

  private closeRoom(): void {
    const draft = this.drawing.draft;
    if (!draft) return;
    if (draft.length < 3) {
      this.say(WORDS.problem({ kind: "few", item: WORDS.roomName(this.drawing.home.rooms.length + 1) }), "error");
      return;
    }
    this.change((d) => {
      d.home.rooms.push({ name: WORDS.roomName(d.home.rooms.length + 1), corners: draft });
      return { home: d.home, draft: null };
    });
  }

  private cancelRoom(): void {
    this.change((d) => ({ ...d, draft: null }));
  }

  private addDoor(p: XY): void {
    const width = this.readNumber(this.doorWidth, WORDS.doorWidth, 0.8);
    if (width === null) return;
    const near = nearestEdge(this.drawing.home, p);
    if (!near || near.distance > DOOR_PICK) {
      this.say(WORDS.noWall, "error");
      return;
    }
    const { a, b } = near.edge;
    // Along an axis-aligned wall the doorway's centre snaps like everything else.
    const at: XY = [
      round(a[0] === b[0] ? a[0] : snap(near.point[0])),
      round(a[1] === b[1] ? a[1] : snap(near.point[1])),
    ];
    this.change((d) => {
      d.home.doorways.push({ name: WORDS.doorName(d.home.doorways.length + 1), at, width });
      return d;
    });
  }

  /** The number typed in `input`, or null (with a message, the input reset to `kept`). */
  private readNumber(input: HTMLInputElement, what: string, kept: number): number | null {
    const text = input.value.trim().replace(",", ".");
    const value = text === "" ? Number.NaN : Number(text);
    if (!Number.isFinite(value)) {
      this.say(WORDS.notNumber(input.value, what, `${kept}`), "error");
      input.value = String(kept);
      input.setAttribute("aria-invalid", "true");
      return null;
    }
    if (value <= 0) {
      this.say(WORDS.notPositive(input.value, what, `${kept}`), "error");
      input.value = String(kept);
      input.setAttribute("aria-invalid", "true");
      return null;
    }
    input.removeAttribute("aria-invalid");
    return round(value);
  }

  // --- the floor-plan image -------------------------------------------------------------

  /** A PNG or JPG (1 cm a pixel until scaled), or a map_server map: its YAML and the
   * PGM (or PNG) it names, placed at the map's own scale and origin. */
  private async openImage(files: File[]): Promise<void> {
    const yamlFile = files.find((f) => /\.ya?ml$/i.test(f.name));
    const name = (yamlFile ?? files[0]).name;
    try {
      let image = files[0];
      let place: { mpp: number; origin: XY } | null = null;
      let negate = false; // map_server's flag: dark is free
      if (yamlFile) {
        const info = parseMapYaml(await yamlFile.text());
        if (typeof info === "string") {
          this.say(WORDS.badMap(yamlFile.name, info), "error");
          return;
        }
        const wanted = info.image.split("/").pop() ?? info.image;
        const found = files.find((f) => f.name === wanted);
        if (!found) {
          this.say(WORDS.mapImageMissing(yamlFile.name, wanted), "error");
          return;
        }
        image = found;
        place = { mpp: info.resolution, origin: info.origin };
        negate = info.negate;
      }
      let url: string;
      let size: XY;
      if (/\.pgm$/i.test(image.name)) {
        const gray = parsePgm(new Uint8Array(await image.arrayBuffer()));
        if (typeof gray === "string") {
          this.say(WORDS.badMap(image.name, gray), "error");
          return;
        }
        url = grayUrl(gray, negate);
        size = [gray.width, gray.height];
      } else {
        if (!/^image\/(png|jpeg)$/.test(image.type)) {
          this.say(WORDS.notImage(image.name), "error");
          return;
        }
        url = await new Promise<string>((resolve, reject) => {
          const reader = new FileReader();
          reader.onload = () => resolve(String(reader.result));
          reader.onerror = () => reject(reader.error);
          reader.readAsDataURL(image);
        });
        size = (await loadImage(url, image.name)).size;
      }
      // Until a length is marked, 1 pixel is 1 cm.
      this.background = { url, width: size[0], height: size[1], mpp: place?.mpp ?? 0.01, origin: place?.origin };
      this.keepImage();
      if (place) this.say(WORDS.mapPlaced(place.mpp), "ready");
      else this.setTool("scale");
      this.drawPlan();
    } catch {
      this.say(WORDS.notImage(name), "error");
    } finally {
      this.imageInput.value = "";
    }
  }

  /** Rooms and doorways found in the floor-plan image, added as one change. */
  private async findRooms(): Promise<void> {
    const bg = this.background;
    if (!bg) {
      this.say(WORDS.noImage, "error");
      return;
    }
    const { image } = await loadImage(bg.url, "the floor-plan image");
    const canvas = el("canvas", { width: `${bg.width}`, height: `${bg.height}` });
    const context = canvas.getContext("2d", { willReadFrequently: true });
    if (!context) return;
    context.drawImage(image, 0, 0);
    const rgba = context.getImageData(0, 0, bg.width, bg.height).data;
    const gray: Gray = { width: bg.width, height: bg.height, pixels: new Uint8Array(bg.width * bg.height) };
    for (let k = 0; k < gray.pixels.length; k++) {
      gray.pixels[k] = Math.round((rgba[4 * k] + rgba[4 * k + 1] + rgba[4 * k + 2]) / 3);
    }
    const found = detectRooms(gray, bg.mpp, bg.origin ?? [0, 0], { wall: this.drawing.home.thickness });
    if (!found.rooms.length) {
      this.say(WORDS.noneFound, "error");
      return;
    }
    this.change((d) => {
      for (const corners of found.rooms) d.home.rooms.push({ name: WORDS.roomName(d.home.rooms.length + 1), corners });
      for (const door of found.doorways) {
        d.home.doorways.push({ name: WORDS.doorName(d.home.doorways.length + 1), ...door });
      }
      return d;
    });
    this.say(WORDS.found(found.rooms.length, found.doorways.length), "ready");
  }

  private keepImage(): void {
    try {
      localStorage.setItem(`${STORAGE_KEY}.image`, JSON.stringify(this.background));
    } catch {
      this.say(WORDS.imageNotKept, "error");
    }
  }

  /** Scale the image so the two marks are the typed length apart. */
  private setScale(): void {
    if (!this.background || this.marks.length !== 2) {
      this.say(WORDS.markFirst, "error");
      return;
    }
    const length = this.readNumber(this.knownLength, WORDS.knownLength, 1);
    if (length === null) return;
    const [a, b] = this.marks;
    const now = Math.hypot(b[0] - a[0], b[1] - a[1]);
    if (now === 0) {
      this.say(WORDS.markFirst, "error");
      return;
    }
    this.background.mpp *= length / now;
    this.marks = [];
    this.keepImage();
    this.say(WORDS.scaled(this.background.mpp), "ready");
    this.drawPlan();
  }

  // --- files and the server --------------------------------------------------------------

  /** The YAML, or null with the problems shown when the home is not complete. */
  private yaml(): string | null {
    const found = problems(this.drawing);
    if (found.length) {
      this.say(`${WORDS.fixFirst} ${found.map((p) => WORDS.problem(p)).join(" ")}`, "error");
      return null;
    }
    return toYaml(this.drawing.home);
  }

  private download(): void {
    const yaml = this.yaml();
    if (yaml === null) return;
    const link = el("a", {
      href: URL.createObjectURL(new Blob([yaml], { type: "application/yaml" })),
      download: "my_home.yaml",
    });
    link.click();
    setTimeout(() => URL.revokeObjectURL(link.href), 10_000);
    this.say(WORDS.downloaded("my_home.yaml"), "ready");
  }

  private async openFile(file: File): Promise<void> {
    try {
      const home = fromYaml(await file.text());
      if (home === null) this.say(WORDS.notAHome(file.name), "error");
      else if (typeof home === "string") this.say(WORDS.badHome(file.name, home), "error");
      else {
        this.change(() => ({ home, draft: null }));
        this.say(WORDS.opened(file.name), "ready");
      }
    } finally {
      this.fileInput.value = "";
    }
  }

  private async send(): Promise<void> {
    const yaml = this.yaml();
    if (yaml === null) return;
    this.say(WORDS.sending, "loading");
    try {
      const entry = await sendWorld(yaml);
      await this.sent(entry);
      this.say(WORDS.sent(entry.name), "ready");
    } catch (err) {
      this.say(err instanceof Error ? err.message : String(err), "error");
    }
  }

  // --- drawing ----------------------------------------------------------------------

  private render(): void {
    this.drawPlan();
    this.drawLists();
    const found = problems(this.drawing);
    this.problemList.replaceChildren(
      ...(found.length
        ? found.map((p) => el("li", { "data-kind": p.kind }, WORDS.problem(p)))
        : [el("li", { class: "ok" }, WORDS.ok)]),
    );
    this.buttons["home-undo"].disabled = !this.undoStack.length;
    this.buttons["home-redo"].disabled = !this.redoStack.length;
    this.buttons["home-close-room"].disabled = !this.drawing.draft;
    this.buttons["home-cancel-room"].disabled = !this.drawing.draft;
  }

  private drawPlan(): void {
    const { home, draft } = this.drawing;
    const checked = this.verdict.planColours(home);
    const points = [...home.rooms.flatMap((r) => r.corners), ...(draft ?? [])];
    const xs = [-1, 13, ...points.map((p) => p[0] - 1), ...points.map((p) => p[0] + 1)];
    const ys = [-1, 10, ...points.map((p) => p[1] - 1), ...points.map((p) => p[1] + 1)];
    if (this.background) {
      const [ox, oy] = this.background.origin ?? [0, 0];
      xs.push(ox, ox + this.background.width * this.background.mpp);
      ys.push(oy, oy + this.background.height * this.background.mpp);
    }
    const [x0, x1, y0, y1] = [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
    this.canvas.setAttribute("viewBox", `${x0} ${-y1} ${x1 - x0} ${y1 - y0}`);
    const parts: SVGElement[] = [];
    const bg = this.background;
    if (bg) {
      // The plan's y points up: the image goes in a flipped group to stand upright.
      const flip = svg("g", { transform: "scale(1,-1)" });
      const w = bg.width * bg.mpp;
      const h = bg.height * bg.mpp;
      const [ox, oy] = bg.origin ?? [0, 0];
      flip.append(
        svg("image", { id: "home-background", href: bg.url, x: ox, y: -(oy + h), width: w, height: h, opacity: 0.5 }),
      );
      parts.push(flip);
    }
    for (let x = Math.ceil(x0); x <= x1; x++) {
      parts.push(svg("line", { x1: x, y1: y0, x2: x, y2: y1, class: "grid" }));
    }
    for (let y = Math.ceil(y0); y <= y1; y++) {
      parts.push(svg("line", { x1: x0, y1: y, x2: x1, y2: y, class: "grid" }));
    }
    home.rooms.forEach((room, i) => {
      const colour = checked?.rooms.get(room.name);
      const poly = svg("polygon", {
        points: room.corners.map((c) => c.join(",")).join(" "),
        class: colour ? `room verdict-${colour}` : "room",
        "data-item": `room-${i}`,
      });
      parts.push(poly);
    });
    for (const w of walls(home)) {
      parts.push(
        svg("line", {
          x1: w.from[0],
          y1: w.from[1],
          x2: w.to[0],
          y2: w.to[1],
          class: "wall",
          "stroke-width": home.thickness,
        }),
      );
    }
    for (const route of checked?.routes ?? []) {
      const points = route.points.map((c) => c.join(",")).join(" ");
      parts.push(svg("polyline", { points, class: `route verdict-${route.colour}` }));
    }
    home.doorways.forEach((d, i) => {
      const colour = checked?.doors[i];
      const near = colour ? nearestEdge(home, d.at) : null;
      if (colour && near) {
        // The doorway's opening along its wall, in the colour its width earns.
        const { a, b } = near.edge;
        const len = Math.hypot(b[0] - a[0], b[1] - a[1]) || 1;
        const [ux, uy] = [((b[0] - a[0]) / len) * (d.width / 2), ((b[1] - a[1]) / len) * (d.width / 2)];
        parts.push(
          svg("line", {
            x1: d.at[0] - ux,
            y1: d.at[1] - uy,
            x2: d.at[0] + ux,
            y2: d.at[1] + uy,
            class: `door-span verdict-${colour}`,
            "stroke-width": home.thickness * 1.5,
          }),
        );
      }
      const cls = colour ? `door verdict-${colour}` : "door";
      parts.push(svg("circle", { cx: d.at[0], cy: d.at[1], r: 0.08, class: cls, "data-item": `door-${i}` }));
    });
    home.furniture.forEach((f, i) => {
      const attrs = { class: "furniture", "data-item": `furniture-${i}` };
      parts.push(
        f.shape === "box"
          ? svg("rect", {
              ...attrs,
              x: f.at[0] - f.size[0] / 2,
              y: f.at[1] - f.size[1] / 2,
              width: f.size[0],
              height: f.size[1],
            })
          : svg("circle", { ...attrs, cx: f.at[0], cy: f.at[1], r: f.size[0] / 2 }),
      );
    });
    home.objects.forEach((o, i) => {
      parts.push(
        svg("rect", {
          class: "object",
          "data-item": `object-${i}`,
          x: o.at[0] - 0.06,
          y: o.at[1] - 0.06,
          width: 0.12,
          height: 0.12,
        }),
      );
    });
    if (home.rooms.length) {
      const s = spawnOf(home);
      parts.push(svg("circle", { cx: s[0], cy: s[1], r: 0.2, class: home.spawn ? "spawn" : "spawn auto" }));
    }
    if (draft) {
      const path = [...draft, ...(this.pointer && this.tool === "room" ? [this.pointer] : [])];
      parts.push(svg("polyline", { points: path.map((c) => c.join(",")).join(" "), class: "draft" }));
      draft.forEach((c, i) => {
        parts.push(svg("circle", { cx: c[0], cy: c[1], r: i === 0 ? 0.12 : 0.06, class: "corner" }));
      });
    }
    for (const m of this.marks) {
      parts.push(svg("circle", { cx: m[0], cy: m[1], r: 0.08, class: "mark" }));
    }
    if (this.marks.length === 2) {
      const [a, b] = this.marks;
      parts.push(svg("line", { x1: a[0], y1: a[1], x2: b[0], y2: b[1], class: "mark" }));
    }
    this.plan.replaceChildren(...parts);
  }

  /** A number field bound to part of the drawing: a valid number changes it (undoable),
   * anything else leaves it and says why. */
  private field(
    id: string,
    label: string,
    value: number,
    what: string,
    apply: (d: Drawing, v: number) => void,
  ): HTMLElement {
    const input = el("input", { id, type: "text", inputmode: "decimal", value: String(round(value)) });
    input.addEventListener("change", () => {
      const v = this.readNumber(input, what, round(value));
      if (v === null) return;
      this.change((d) => {
        apply(d, v);
        return d;
      });
    });
    return el("label", {}, el("span", {}, label), input);
  }

  private nameField(id: string, value: string, apply: (d: Drawing, v: string) => void): HTMLElement {
    const input = el("input", { id, type: "text", value });
    input.addEventListener("change", () => {
      const v = input.value.trim();
      if (!v) {
        input.value = value;
        return;
      }
      this.change((d) => {
        apply(d, v);
        return d;
      });
    });
    return el("label", {}, el("span", {}, WORDS.fields.name), input);
  }

  private remove(id: string, apply: (h: Home) => void): HTMLButtonElement {
    const b = el("button", { type: "button", id, class: "remove" }, WORDS.fields.remove);
    b.addEventListener("click", () =>
      this.change((d) => {
        apply(d.home);
        return d;
      }),
    );
    return b;
  }

  private drawLists(): void {
    const { home } = this.drawing;
    const F = WORDS.fields;
    const group = (title: string, rows: HTMLElement[]): HTMLElement =>
      el("fieldset", {}, el("legend", {}, title), ...(rows.length ? rows : [el("p", { class: "hint" }, WORDS.nothing)]));
    const row = (id: string, ...children: HTMLElement[]): HTMLElement =>
      el("div", { class: "home-row", id: `row-${id}` }, ...children);
    const at = (id: string, what: string, p: XY, set: (d: Drawing, q: XY) => void): HTMLElement[] => [
      this.field(`${id}-x`, F.x, p[0], `${what} x`, (d, v) => set(d, [v, p[1]])),
      this.field(`${id}-y`, F.y, p[1], `${what} y`, (d, v) => set(d, [p[0], v])),
    ];
    this.lists.replaceChildren(
      group(WORDS.lists.walls, [
        row(
          "walls",
          this.field("home-thickness", F.thickness, home.thickness, F.thickness, (d, v) => {
            d.home.thickness = v;
          }),
          this.field("home-height", F.height, home.height, F.height, (d, v) => {
            d.home.height = v;
          }),
        ),
      ]),
      group(
        WORDS.lists.rooms,
        home.rooms.map((room, i) =>
          row(
            `room-${i}`,
            this.nameField(`room-${i}-name`, room.name, (d, v) => {
              d.home.rooms[i].name = v;
            }),
            ...room.corners.map((_, k) =>
              this.field(
                `room-${i}-edge-${k + 1}`,
                F.edge(k + 1),
                edgeLength(room.corners, k),
                `${room.name} edge ${k + 1}`,
                (d, v) => {
                  d.home.rooms[i].corners = setEdgeLength(d.home.rooms[i].corners, k, v);
                },
              ),
            ),
            this.remove(`room-${i}-remove`, (h) => h.rooms.splice(i, 1)),
          ),
        ),
      ),
      group(
        WORDS.lists.doorways,
        home.doorways.map((door, i) =>
          row(
            `door-${i}`,
            el("strong", {}, door.name),
            this.field(`door-${i}-width`, F.width, door.width, `${door.name} width`, (d, v) => {
              d.home.doorways[i].width = v;
            }),
            ...at(`door-${i}`, door.name, door.at, (d, q) => {
              d.home.doorways[i].at = q;
            }),
            this.remove(`door-${i}-remove`, (h) => h.doorways.splice(i, 1)),
          ),
        ),
      ),
      group(
        WORDS.lists.furniture,
        home.furniture.map((f, i) =>
          row(
            `furniture-${i}`,
            this.nameField(`furniture-${i}-name`, f.name, (d, v) => {
              d.home.furniture[i].name = v;
            }),
            ...at(`furniture-${i}`, f.name, f.at, (d, q) => {
              d.home.furniture[i].at = q;
            }),
            ...(f.shape === "box"
              ? [
                  this.field(`furniture-${i}-width`, F.width, f.size[0], `${f.name} width`, (d, v) => {
                    d.home.furniture[i].size[0] = v;
                  }),
                  this.field(`furniture-${i}-depth`, F.depth, f.size[1], `${f.name} depth`, (d, v) => {
                    d.home.furniture[i].size[1] = v;
                  }),
                ]
              : [
                  this.field(`furniture-${i}-width`, F.diameter, f.size[0], `${f.name} diameter`, (d, v) => {
                    d.home.furniture[i].size = [v, v];
                  }),
                ]),
            this.field(`furniture-${i}-height`, F.height, f.height, `${f.name} height`, (d, v) => {
              d.home.furniture[i].height = v;
            }),
            this.remove(`furniture-${i}-remove`, (h) => h.furniture.splice(i, 1)),
          ),
        ),
      ),
      group(
        WORDS.lists.objects,
        home.objects.map((o, i) =>
          row(
            `object-${i}`,
            this.nameField(`object-${i}-name`, o.name, (d, v) => {
              d.home.objects[i].name = v;
            }),
            ...at(`object-${i}`, o.name, o.at, (d, q) => {
              d.home.objects[i].at = q;
            }),
            this.field(`object-${i}-size`, F.size, o.size, `${o.name} size`, (d, v) => {
              d.home.objects[i].size = v;
            }),
            this.remove(`object-${i}-remove`, (h) => h.objects.splice(i, 1)),
          ),
        ),
      ),
      group(WORDS.lists.spawn, [
        home.spawn
          ? row(
              "spawn",
              ...at("spawn", WORDS.lists.spawn, home.spawn, (d, q) => {
                d.home.spawn = q;
              }),
              this.remove("spawn-remove", (h) => {
                h.spawn = null;
              }),
            )
          : el("p", { class: "hint" }, WORDS.spawnAuto),
      ]),
    );
  }
}
