// "My home": the floor plan a household draws (rooms, doorways, furniture, objects, the
// robot's start) and what it becomes: the World YAML the platform reads (docs/worlds.md).
// Walls run along the room outlines (shared edges become one wall), doorways are gaps
// in them, furniture are static bodies, objects small movable boxes. The plan itself is
// kept in the YAML as `home:` (one JSON line, which is YAML too) so the file opens here
// again; the server checks that section (robotrial.model.home).

export type XY = [number, number];

export interface HomeRoom {
  name: string;
  corners: XY[];
}

export interface Doorway {
  name: string;
  at: XY;
  width: number;
}

export type FurnitureShape = "box" | "cylinder";

export interface Furniture {
  name: string;
  shape: FurnitureShape;
  at: XY;
  /** box: [width along x, depth along y]; cylinder: [diameter, diameter]. */
  size: XY;
  height: number;
}

export interface FetchObject {
  name: string;
  at: XY;
  size: number;
}

export interface Home {
  version: 1;
  thickness: number;
  height: number;
  rooms: HomeRoom[];
  doorways: Doorway[];
  furniture: Furniture[];
  objects: FetchObject[];
  spawn: XY | null;
}

/** What the editor keeps: the home and the room being drawn (corners so far). */
export interface Drawing {
  home: Home;
  draft: XY[] | null;
}

export type Problem =
  | { kind: "open" | "few"; item: string }
  | { kind: "crossing"; item: string; a: number; b: number }
  | { kind: "empty" }
  | { kind: "offWall" | "narrow" | "wide"; item: string; value: number; limit: number }
  | { kind: "overlap"; item: string; other: string }
  | { kind: "duplicate"; item: string };

export const SNAP = 0.05;
/** How far (m) beyond half the wall thickness a doorway's centre may sit from a wall. */
export const DOOR_TOLERANCE = 0.01;
export const OBJECT_MASS = 0.2;

/** How far in from a table's edge (m) a chore sets things down (docs/web.md, My home). */
export const PLACE_INSET = 0.12;

export const PRESETS: Record<string, Omit<Furniture, "at">> = {
  table: { name: "table", shape: "box", size: [1.2, 0.8], height: 0.75 },
  round_table: { name: "round table", shape: "cylinder", size: [1.0, 1.0], height: 0.75 },
  counter: { name: "counter", shape: "box", size: [2.0, 0.6], height: 0.9 },
  shelf: { name: "shelf", shape: "box", size: [0.8, 0.35], height: 1.8 },
  bed: { name: "bed", shape: "box", size: [2.0, 1.6], height: 0.5 },
  sofa: { name: "sofa", shape: "box", size: [2.0, 0.9], height: 0.8 },
};

export function emptyHome(): Home {
  return {
    version: 1,
    thickness: 0.1,
    height: 2.0,
    rooms: [],
    doorways: [],
    furniture: [],
    objects: [],
    spawn: null,
  };
}

export function snap(v: number): number {
  return Math.round(v / SNAP) * SNAP;
}

/** Millimetres are enough: keeps 0.1 + 0.2 from printing as 0.30000000000000004. */
export function round(v: number): number {
  return Math.round(v * 1000) / 1000;
}

export function edgeLength(corners: XY[], k: number): number {
  const a = corners[k];
  const b = corners[(k + 1) % corners.length];
  return Math.hypot(b[0] - a[0], b[1] - a[1]);
}

/** Set edge k of a room to `length`: its end corner moves along the edge and so does the
 * next corner, so the following edge keeps its direction (a rectangle stays one). */
export function setEdgeLength(corners: XY[], k: number, length: number): XY[] {
  const n = corners.length;
  const a = corners[k];
  const b = corners[(k + 1) % n];
  const now = Math.hypot(b[0] - a[0], b[1] - a[1]);
  if (now === 0) return corners;
  const dx = ((b[0] - a[0]) / now) * (length - now);
  const dy = ((b[1] - a[1]) / now) * (length - now);
  const moved = new Set([(k + 1) % n]);
  if (n > 3) moved.add((k + 2) % n);
  moved.delete(k);
  return corners.map((c, i) => (moved.has(i) ? [round(c[0] + dx), round(c[1] + dy)] : c));
}

function cross(o: XY, a: XY, b: XY): number {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

function segmentsCross(a: XY, b: XY, c: XY, d: XY): boolean {
  return cross(c, d, a) * cross(c, d, b) < 0 && cross(a, b, c) * cross(a, b, d) < 0;
}

/** The nearest point of segment ab to p, and how far it is. */
export function nearestOnSegment(p: XY, a: XY, b: XY): { point: XY; distance: number } {
  const ax = b[0] - a[0];
  const ay = b[1] - a[1];
  const l2 = ax * ax + ay * ay;
  const t = l2 === 0 ? 0 : Math.max(0, Math.min(1, ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / l2));
  const point: XY = [a[0] + t * ax, a[1] + t * ay];
  return { point, distance: Math.hypot(p[0] - point[0], p[1] - point[1]) };
}

export interface Edge {
  room: number;
  index: number;
  a: XY;
  b: XY;
}

export function edges(home: Home): Edge[] {
  const out: Edge[] = [];
  home.rooms.forEach((room, r) => {
    room.corners.forEach((a, k) => {
      out.push({ room: r, index: k, a, b: room.corners[(k + 1) % room.corners.length] });
    });
  });
  return out;
}

/** The wall edge nearest to p, or null in a home without rooms. */
export function nearestEdge(home: Home, p: XY): { edge: Edge; point: XY; distance: number } | null {
  let best: { edge: Edge; point: XY; distance: number } | null = null;
  for (const edge of edges(home)) {
    const near = nearestOnSegment(p, edge.a, edge.b);
    if (!best || near.distance < best.distance) best = { edge, ...near };
  }
  return best;
}

function footprintsOverlap(a: Furniture, b: Furniture): boolean {
  const eps = 1e-3;
  if (a.shape === "cylinder" && b.shape === "cylinder") {
    return Math.hypot(a.at[0] - b.at[0], a.at[1] - b.at[1]) < (a.size[0] + b.size[0]) / 2 - eps;
  }
  if (a.shape === "cylinder" || b.shape === "cylinder") {
    const [circle, box] = a.shape === "cylinder" ? [a, b] : [b, a];
    const dx = Math.max(Math.abs(circle.at[0] - box.at[0]) - box.size[0] / 2, 0);
    const dy = Math.max(Math.abs(circle.at[1] - box.at[1]) - box.size[1] / 2, 0);
    return Math.hypot(dx, dy) < circle.size[0] / 2 - eps;
  }
  return (
    Math.abs(a.at[0] - b.at[0]) < (a.size[0] + b.size[0]) / 2 - eps &&
    Math.abs(a.at[1] - b.at[1]) < (a.size[1] + b.size[1]) / 2 - eps
  );
}

/** Everything that keeps the drawing from being a home the platform can load. */
export function problems(drawing: Drawing): Problem[] {
  const { home, draft } = drawing;
  const out: Problem[] = [];
  if (draft) out.push({ kind: "open", item: `Room ${home.rooms.length + 1}` });
  if (!home.rooms.length && !draft) out.push({ kind: "empty" });
  for (const room of home.rooms) {
    const c = room.corners;
    if (c.length < 3) {
      out.push({ kind: "few", item: room.name });
      continue;
    }
    for (let k = 0; k < c.length; k++) {
      for (let j = k + 2; j < c.length; j++) {
        if (k === 0 && j === c.length - 1) continue;
        if (segmentsCross(c[k], c[(k + 1) % c.length], c[j], c[(j + 1) % c.length])) {
          out.push({ kind: "crossing", item: room.name, a: k + 1, b: j + 1 });
        }
      }
    }
  }
  for (const door of home.doorways) {
    const near = nearestEdge(home, door.at);
    if (!near) continue;
    if (near.distance > home.thickness / 2 + DOOR_TOLERANCE) {
      out.push({ kind: "offWall", item: door.name, value: near.distance, limit: 0 });
      continue;
    }
    if (door.width < home.thickness) {
      out.push({ kind: "narrow", item: door.name, value: door.width, limit: home.thickness });
    }
    const length = edgeLength(home.rooms[near.edge.room].corners, near.edge.index);
    if (door.width > length) {
      out.push({ kind: "wide", item: door.name, value: door.width, limit: length });
    }
  }
  const f = home.furniture;
  for (let i = 0; i < f.length; i++) {
    for (let j = 0; j < i; j++) {
      if (footprintsOverlap(f[i], f[j])) out.push({ kind: "overlap", item: f[i].name, other: f[j].name });
    }
  }
  const names = [...f.map((x) => x.name), ...home.objects.map((x) => x.name)].map(bodyName);
  for (const name of new Set(names.filter((n, i) => names.indexOf(n) !== i))) {
    out.push({ kind: "duplicate", item: name });
  }
  return out;
}

/** A body name for the world file: "Round table" -> "round_table". */
export function bodyName(text: string): string {
  return text.toLowerCase().replace(/[^a-z0-9]+/g, "_").replace(/^_+|_+$/g, "") || "item";
}

export interface WallSegment {
  from: XY;
  to: XY;
}

/** The walls: every room edge, edges on one line merged (a shared wall is one wall),
 * stretched by half the thickness at their ends (closed corners), doorways cut out. */
export function walls(home: Home): WallSegment[] {
  const lines = new Map<string, { u: XY; n: XY; c: number; spans: XY[] }>();
  for (const { a, b } of edges(home)) {
    const len = Math.hypot(b[0] - a[0], b[1] - a[1]);
    if (len === 0) continue;
    let u: XY = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
    if (u[0] < -1e-9 || (Math.abs(u[0]) <= 1e-9 && u[1] < 0)) u = [-u[0], -u[1]];
    const n: XY = [-u[1], u[0]];
    const c = n[0] * a[0] + n[1] * a[1];
    const key = `${u[0].toFixed(5)},${u[1].toFixed(5)},${c.toFixed(4)}`;
    const line = lines.get(key) ?? { u, n, c, spans: [] };
    const s0 = u[0] * a[0] + u[1] * a[1];
    const s1 = u[0] * b[0] + u[1] * b[1];
    line.spans.push([Math.min(s0, s1), Math.max(s0, s1)]);
    lines.set(key, line);
  }
  const half = home.thickness / 2;
  const out: WallSegment[] = [];
  for (const line of lines.values()) {
    const merged: XY[] = [];
    for (const [s0, s1] of line.spans.sort((p, q) => p[0] - q[0])) {
      const last = merged[merged.length - 1];
      if (last && s0 <= last[1] + 1e-6) last[1] = Math.max(last[1], s1);
      else merged.push([s0, s1]);
    }
    let pieces: XY[] = merged.map(([s0, s1]) => [s0 - half, s1 + half]);
    for (const door of home.doorways) {
      const off = line.n[0] * door.at[0] + line.n[1] * door.at[1] - line.c;
      if (Math.abs(off) > half + DOOR_TOLERANCE) continue;
      const s = line.u[0] * door.at[0] + line.u[1] * door.at[1];
      const cut: XY = [s - door.width / 2, s + door.width / 2];
      pieces = pieces.flatMap(([p0, p1]) => {
        if (cut[1] <= p0 || cut[0] >= p1 || s < p0 || s > p1) return [[p0, p1] as XY];
        const keep: XY[] = [];
        if (cut[0] - p0 > 1e-6) keep.push([p0, cut[0]]);
        if (p1 - cut[1] > 1e-6) keep.push([cut[1], p1]);
        return keep;
      });
    }
    const at = (s: number): XY => [
      round(line.c * line.n[0] + s * line.u[0]),
      round(line.c * line.n[1] + s * line.u[1]),
    ];
    for (const [s0, s1] of pieces) out.push({ from: at(s0), to: at(s1) });
  }
  return out;
}

function bounds(points: XY[]): [XY, XY] {
  const xs = points.map((p) => p[0]);
  const ys = points.map((p) => p[1]);
  return [
    [Math.min(...xs), Math.min(...ys)],
    [Math.max(...xs), Math.max(...ys)],
  ];
}

/** Where the robot starts: placed by the user, or the middle of the first room. */
export function spawnOf(home: Home): XY {
  if (home.spawn) return home.spawn;
  const [lo, hi] = bounds(home.rooms[0].corners);
  return [round((lo[0] + hi[0]) / 2), round((lo[1] + hi[1]) / 2)];
}

/** The furniture an object at `p` lies on (its top is the object's floor), if any. */
function under(home: Home, p: XY): Furniture | undefined {
  return home.furniture.find((f) =>
    f.shape === "cylinder"
      ? Math.hypot(p[0] - f.at[0], p[1] - f.at[1]) <= f.size[0] / 2
      : Math.abs(p[0] - f.at[0]) <= f.size[0] / 2 && Math.abs(p[1] - f.at[1]) <= f.size[1] / 2,
  );
}

/** Where a chore sets things down in a room: on the piece of furniture at table height
 * (0.4-1.0 m) with the largest top among those standing in the room, PLACE_INSET in from
 * its edge nearest the room's middle; null when the room has none. */
export function placeIn(home: Home, room: HomeRoom): { surface: string; at: XY } | null {
  const [lo, hi] = bounds(room.corners);
  const inside = (p: XY) => p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1];
  const top = (f: Furniture) => f.size[0] * f.size[1];
  const tables = home.furniture
    .filter((f) => inside(f.at) && f.height >= 0.4 && f.height <= 1.0)
    .sort((a, b) => top(b) - top(a));
  const f = tables[0];
  if (!f) return null;
  const middle: XY = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2];
  let at: XY;
  if (f.shape === "cylinder") {
    const d = Math.hypot(middle[0] - f.at[0], middle[1] - f.at[1]);
    const r = Math.min(d, Math.max(0, f.size[0] / 2 - PLACE_INSET));
    at = d > 0 ? [f.at[0] + ((middle[0] - f.at[0]) * r) / d, f.at[1] + ((middle[1] - f.at[1]) * r) / d] : f.at;
  } else {
    const clamp = (v: number, c: number, half: number) => {
      const room = Math.max(0, half - PLACE_INSET);
      return Math.min(c + room, Math.max(c - room, v));
    };
    at = [clamp(middle[0], f.at[0], f.size[0] / 2), clamp(middle[1], f.at[1], f.size[1] / 2)];
  }
  return { surface: bodyName(f.name), at };
}

const num = (v: number): string => String(round(v));
const xy = (p: XY): string => `[${num(p[0])}, ${num(p[1])}]`;
const text = (s: string): string => JSON.stringify(s);

/** The World YAML of a home (docs/worlds.md), with the plan itself as `home:`. Call it
 * on a home without problems. */
export function toYaml(home: Home, name = "my_home"): string {
  const all = home.rooms.flatMap((r) => r.corners);
  const [lo, hi] = bounds(all);
  const t = home.thickness;
  const lines: string[] = [
    "# A home drawn in the robotrial page (docs/web.md, My home).",
    `name: ${text(name)}`,
    `description: ${text(`A home with ${home.rooms.length} room${home.rooms.length === 1 ? "" : "s"}`)}`,
    `floor: {size: ${xy([hi[0] - lo[0] + 2, hi[1] - lo[1] + 2])}, center: ${xy([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2])}}`,
    `interior: [${xy([lo[0] + t / 2, lo[1] + t / 2])}, ${xy([hi[0] - t / 2, hi[1] - t / 2])}]`,
    `wall_defaults: {thickness: ${num(t)}, height: ${num(home.height)}}`,
    "walls:",
  ];
  walls(home).forEach((w, i) => {
    lines.push(`  - {name: wall${i + 1}, from: ${xy(w.from)}, to: ${xy(w.to)}}`);
  });
  lines.push(home.furniture.length ? "obstacles:" : "obstacles: []");
  for (const f of home.furniture) {
    const pose = `pose: {xyz: [${num(f.at[0])}, ${num(f.at[1])}, ${num(f.height / 2)}]}`;
    const shape =
      f.shape === "box"
        ? `shape: box, size: [${num(f.size[0])}, ${num(f.size[1])}, ${num(f.height)}]`
        : `shape: cylinder, radius: ${num(f.size[0] / 2)}, length: ${num(f.height)}`;
    lines.push(`  - {name: ${text(bodyName(f.name))}, kind: furniture, ${shape}, ${pose}}`);
  }
  lines.push(home.objects.length ? "objects:" : "objects: []");
  for (const o of home.objects) {
    const base = under(home, o.at)?.height ?? 0;
    const pose = `pose: {xyz: [${num(o.at[0])}, ${num(o.at[1])}, ${num(base + o.size / 2)}]}`;
    const s = num(o.size);
    lines.push(
      `  - {name: ${text(bodyName(o.name))}, shape: box, size: [${s}, ${s}, ${s}], mass: ${OBJECT_MASS}, ${pose}}`,
    );
  }
  const spawn = spawnOf(home);
  lines.push("spawns:", `  default: [${num(spawn[0])}, ${num(spawn[1])}, 0.0]`, "rooms:");
  for (const room of home.rooms) {
    const [rlo, rhi] = bounds(room.corners);
    const place = placeIn(home, room);
    const where = place ? `, place: {surface: ${text(place.surface)}, xy: ${xy(place.at)}}` : "";
    lines.push(`  - {name: ${text(room.name)}, min: ${xy(rlo)}, max: ${xy(rhi)}${where}}`);
  }
  lines.push(`home: ${JSON.stringify(home)}`, "");
  return lines.join("\n");
}

function isXY(v: unknown): v is XY {
  return Array.isArray(v) && v.length === 2 && v.every((x) => typeof x === "number" && Number.isFinite(x));
}

function positive(v: unknown): v is number {
  return typeof v === "number" && Number.isFinite(v) && v > 0;
}

/** The plan kept in a home's YAML (its `home:` line), or a reason it cannot be read:
 * `null` when the file has no home section at all. */
export function fromYaml(yaml: string): Home | string | null {
  const line = yaml.split(/\r?\n/).find((l) => l.startsWith("home:"));
  if (!line) return null;
  let data: unknown;
  try {
    data = JSON.parse(line.slice("home:".length));
  } catch {
    return "its home line is not the one this editor writes";
  }
  return checkShape(data);
}

/** `data` as a Home if it has the Home's shape, else a reason naming the item. */
export function checkShape(data: unknown): Home | string {
  if (typeof data !== "object" || data === null) return "home is not a mapping";
  const h = data as Record<string, unknown>;
  if (!positive(h.thickness)) return "home.thickness must be a positive number";
  if (!positive(h.height)) return "home.height must be a positive number";
  for (const key of ["rooms", "doorways", "furniture", "objects"]) {
    if (!Array.isArray(h[key])) return `home.${key} must be a list`;
  }
  const rooms = h.rooms as Record<string, unknown>[];
  for (const [i, r] of rooms.entries()) {
    if (typeof r?.name !== "string" || !Array.isArray(r.corners) || !r.corners.every(isXY)) {
      return `home.rooms[${i}] needs a name and corners [[x, y], …]`;
    }
  }
  for (const [i, d] of (h.doorways as Record<string, unknown>[]).entries()) {
    if (typeof d?.name !== "string" || !isXY(d.at) || !positive(d.width)) {
      return `home.doorways[${i}] needs a name, at [x, y] and a positive width`;
    }
  }
  for (const [i, f] of (h.furniture as Record<string, unknown>[]).entries()) {
    const ok =
      typeof f?.name === "string" &&
      (f.shape === "box" || f.shape === "cylinder") &&
      isXY(f.at) &&
      isXY(f.size) &&
      f.size.every(positive) &&
      positive(f.height);
    if (!ok) return `home.furniture[${i}] needs a name, shape, at, size and height`;
  }
  for (const [i, o] of (h.objects as Record<string, unknown>[]).entries()) {
    if (typeof o?.name !== "string" || !isXY(o.at) || !positive(o.size)) {
      return `home.objects[${i}] needs a name, at [x, y] and a positive size`;
    }
  }
  if (h.spawn !== null && h.spawn !== undefined && !isXY(h.spawn)) return "home.spawn must be [x, y]";
  return { ...(h as unknown as Home), version: 1, spawn: (h.spawn as XY | undefined) ?? null };
}

/** A doorway or a piece of furniture measured in the room itself (AR, ar/measure.ts),
 * added to a copy of `home`. A doorway whose centre lies within `pick` m of a wall moves
 * onto that wall; further away it is added as measured, for the user to place. Furniture
 * takes the first free name from its own ("counter", "counter 2", …). Returns the new
 * home, the name given and the room whose wall holds the doorway (null if none). */
export function addMeasured(
  home: Home,
  item: { doorway: Doorway } | { furniture: Furniture },
  pick = 0.4,
): { home: Home; name: string; room: string | null } {
  const next = structuredClone(home);
  if ("furniture" in item) {
    const taken = new Set(next.furniture.map((f) => f.name));
    let name = item.furniture.name;
    for (let i = 2; taken.has(name); i++) name = `${item.furniture.name} ${i}`;
    next.furniture.push({ ...structuredClone(item.furniture), name });
    return { home: next, name, room: null };
  }
  const door = structuredClone(item.doorway);
  const near = nearestEdge(next, door.at);
  const onWall = near !== null && near.distance <= pick;
  if (onWall) {
    const { a, b } = near.edge;
    door.at = [round(a[0] === b[0] ? a[0] : near.point[0]), round(a[1] === b[1] ? a[1] : near.point[1])];
  }
  next.doorways.push(door);
  return { home: next, name: door.name, room: onWall ? next.rooms[near.edge.room].name : null };
}
