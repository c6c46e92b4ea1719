// Floor-plan files under the home editor: a ROS map_server map (PGM image plus its YAML,
// which gives the scale and where the image lies) read into a picture, and the rooms
// and doorways of a plan found in its pixels (dark is wall, light is floor). Pure
// functions over pixel arrays; the editor does the file reading and the drawing.

import { type Doorway, type XY, round, snap } from "./model";

/** A grey image, one byte a pixel, rows from the top. */
export interface Gray {
  width: number;
  height: number;
  pixels: Uint8Array;
}

/** What the editor reads from a map_server YAML: where its image is and how it lies. */
export interface MapInfo {
  image: string;
  resolution: number;
  origin: XY;
  negate: boolean;
}

/** Rooms (their corners) and doorways found in a plan, in metres. */
export interface Found {
  rooms: XY[][];
  doorways: Omit<Doorway, "name">[];
}

/** Read a binary (P5) or plain (P2) PGM; a string names what is wrong. */
export function parsePgm(bytes: Uint8Array): Gray | string {
  const magic = String.fromCharCode(bytes[0] ?? 0, bytes[1] ?? 0);
  if (magic !== "P5" && magic !== "P2") return "not a PGM image (it does not start with P5 or P2)";
  const fields: number[] = [];
  let i = 2;
  // Header: width, height, maxval, as whitespace-separated numbers; # starts a comment.
  while (fields.length < 3 && i < bytes.length) {
    const c = bytes[i];
    if (c === 0x23) {
      while (i < bytes.length && bytes[i] !== 0x0a) i++;
    } else if (c >= 0x30 && c <= 0x39) {
      let v = 0;
      while (i < bytes.length && bytes[i] >= 0x30 && bytes[i] <= 0x39) v = v * 10 + bytes[i++] - 0x30;
      fields.push(v);
      continue;
    } else if (c !== 0x20 && c !== 0x09 && c !== 0x0a && c !== 0x0d) {
      return `unexpected character in the PGM header at byte ${i}`;
    }
    i++;
  }
  const [width, height, maxval] = fields;
  if (fields.length < 3 || !width || !height || !maxval || maxval > 65535) {
    return "the PGM header lacks a width, height or maximum value";
  }
  const n = width * height;
  const pixels = new Uint8Array(n);
  const scale = 255 / maxval;
  if (magic === "P5") {
    i++; // the single whitespace after maxval
    const wide = maxval > 255 ? 2 : 1;
    if (bytes.length - i < n * wide) return `the PGM holds ${bytes.length - i} bytes of pixels, ${n * wide} expected`;
    for (let k = 0; k < n; k++) {
      const v = wide === 2 ? (bytes[i + 2 * k] << 8) | bytes[i + 2 * k + 1] : bytes[i + k];
      pixels[k] = Math.round(v * scale);
    }
  } else {
    const rest = new TextDecoder().decode(bytes.subarray(i)).trim().split(/\s+/);
    if (rest.length < n) return `the PGM holds ${rest.length} pixels, ${n} expected`;
    for (let k = 0; k < n; k++) pixels[k] = Math.round(Number(rest[k]) * scale);
  }
  return { width, height, pixels };
}

/** Read the keys of a map_server YAML; a string names what is missing or wrong. */
export function parseMapYaml(text: string): MapInfo | string {
  const value = (key: string): string | undefined =>
    text.match(new RegExp(`^\\s*${key}\\s*:\\s*(.+?)\\s*(#.*)?$`, "m"))?.[1];
  const image = value("image")?.replace(/^["']|["']$/g, "");
  const resolution = Number(value("resolution"));
  const origin = (value("origin") ?? "").replace(/[[\]]/g, "").split(",").map(Number);
  if (!image) return "it names no image";
  if (!(resolution > 0)) return "its resolution is missing or not a positive number";
  if (origin.length < 2 || origin.slice(0, 2).some((v) => !Number.isFinite(v))) {
    return "its origin is missing (expected [x, y, yaw])";
  }
  return {
    image,
    resolution,
    origin: [origin[0], origin[1]],
    negate: ["1", "true"].includes((value("negate") ?? "0").toLowerCase()),
  };
}

/** Light pixels (floor) of a grey image: below `darkest` (0-255) counts as wall. */
function floorOf(gray: Gray, darkest = 128): Uint8Array {
  const floor = new Uint8Array(gray.pixels.length);
  for (let k = 0; k < floor.length; k++) floor[k] = gray.pixels[k] >= darkest ? 1 : 0;
  return floor;
}

/** Grow the walls (0 cells) by `r` cells in every direction: a square dilation, two
 * passes of running counts. */
function grownWalls(floor: Uint8Array, w: number, h: number, r: number): Uint8Array {
  const rows = new Uint8Array(floor.length);
  for (let y = 0; y < h; y++) {
    let walls = 0;
    for (let x = 0; x < Math.min(r, w); x++) walls += floor[y * w + x] ? 0 : 1;
    for (let x = 0; x < w; x++) {
      if (x + r < w) walls += floor[y * w + x + r] ? 0 : 1;
      if (x - r - 1 >= 0) walls -= floor[y * w + x - r - 1] ? 0 : 1;
      rows[y * w + x] = walls > 0 ? 0 : 1;
    }
  }
  const out = new Uint8Array(floor.length);
  for (let x = 0; x < w; x++) {
    let walls = 0;
    for (let y = 0; y < Math.min(r, h); y++) walls += rows[y * w + x] ? 0 : 1;
    for (let y = 0; y < h; y++) {
      if (y + r < h) walls += rows[(y + r) * w + x] ? 0 : 1;
      if (y - r - 1 >= 0) walls -= rows[(y - r - 1) * w + x] ? 0 : 1;
      out[y * w + x] = walls > 0 ? 0 : 1;
    }
  }
  return out;
}

/** Connected floor regions (4-neighbours) that do not touch the image's border: their
 * pixel bounds [x0, y0, x1, y1] (inclusive). */
function regions(floor: Uint8Array, w: number, h: number): number[][] {
  const seen = new Uint8Array(floor.length);
  const out: number[][] = [];
  const stack: number[] = [];
  for (let start = 0; start < floor.length; start++) {
    if (!floor[start] || seen[start]) continue;
    seen[start] = 1;
    stack.push(start);
    let [x0, y0, x1, y1, border] = [w, h, 0, 0, false];
    while (stack.length) {
      const k = stack.pop() as number;
      const x = k % w;
      const y = (k - x) / w;
      x0 = Math.min(x0, x);
      x1 = Math.max(x1, x);
      y0 = Math.min(y0, y);
      y1 = Math.max(y1, y);
      if (x === 0 || y === 0 || x === w - 1 || y === h - 1) border = true;
      for (const n of [x > 0 ? k - 1 : -1, x < w - 1 ? k + 1 : -1, y > 0 ? k - w : -1, y < h - 1 ? k + w : -1]) {
        if (n >= 0 && floor[n] && !seen[n]) {
          seen[n] = 1;
          stack.push(n);
        }
      }
    }
    if (!border) out.push([x0, y0, x1, y1]);
  }
  return out;
}

/**
 * Rooms and doorways of a plan. Doorways up to `maxDoor` metres wide are closed by
 * growing the walls by half that; each enclosed floor region larger than `minRoom`
 * square metres becomes a rectangular room reaching to the middle of its walls (`wall`
 * metres thick); a run of floor at least `minDoor` long across the wall between two
 * rooms (walls up to `maxWall` thick) becomes a doorway. Pixel (0, 0) is the image's top-left corner; `origin` is
 * where its bottom-left corner lies in metres (map_server's convention).
 */
export function detectRooms(
  gray: Gray,
  mpp: number,
  origin: XY = [0, 0],
  { maxDoor = 1.2, minDoor = 0.5, minRoom = 2.0, wall = 0.1, maxWall = 0.4 } = {},
): Found {
  const { width: w, height: h } = gray;
  const floor = floorOf(gray);
  const r = Math.max(1, Math.ceil(maxDoor / 2 / mpp));
  const closed = grownWalls(floor, w, h, r);
  const toX = (px: number): number => origin[0] + px * mpp;
  const toY = (py: number): number => origin[1] + (h - py) * mpp;
  // Each enclosed region shrank by r on every side when the walls grew: give it back.
  // Boxes are [x0, y0, x1, y1] in metres, the faces of the walls around the floor.
  const boxes: number[][] = [];
  for (const box of regions(closed, w, h)) {
    const b = [toX(box[0] - r), toY(box[3] + r + 1), toX(box[2] + r + 1), toY(box[1] - r)];
    if ((b[2] - b[0]) * (b[3] - b[1]) >= minRoom) boxes.push(b);
  }
  // Two rooms with a wall between them share its middle line; every other side reaches
  // half a wall out, to where its wall's middle would be.
  const shared = boxes.map(() => [false, false, false, false]);
  for (let i = 0; i < boxes.length; i++) {
    for (let j = 0; j < boxes.length; j++) {
      const [a, b] = [boxes[i], boxes[j]];
      for (const axis of [0, 1]) {
        const other = 1 - axis;
        const gap = b[axis] - a[axis + 2];
        const overlap = Math.min(a[other + 2], b[other + 2]) - Math.max(a[other], b[other]);
        if (i === j || gap < 0 || gap > maxWall || overlap <= 0) continue;
        const mid = (a[axis + 2] + b[axis]) / 2;
        [a[axis + 2], b[axis]] = [mid, mid];
        shared[i][axis + 2] = shared[j][axis] = true;
      }
    }
  }
  const half = wall / 2;
  const placed = boxes.map((b, i) =>
    b.map((v, k) => round(snap(shared[i][k] ? v : v + (k < 2 ? -half : half)))),
  );
  const rooms = placed.map(([a, c, b, d]): XY[] => [[a, c], [b, c], [b, d], [a, d]]);
  return { rooms, doorways: doorsBetween(placed, floor, w, h, mpp, origin, minDoor) };
}

/** Doorways: along every edge two rooms share, the runs of floor in the image. */
function doorsBetween(
  boxes: number[][],
  floor: Uint8Array,
  w: number,
  h: number,
  mpp: number,
  origin: XY,
  minDoor: number,
): Omit<Doorway, "name">[] {
  const free = (x: number, y: number): boolean => {
    const px = Math.floor((x - origin[0]) / mpp);
    const py = h - 1 - Math.floor((y - origin[1]) / mpp);
    return px >= 0 && py >= 0 && px < w && py < h && floor[py * w + px] === 1;
  };
  const out: Omit<Doorway, "name">[] = [];
  const runs = (fixed: number, lo: number, hi: number, vertical: boolean): void => {
    let start: number | null = null;
    for (let s = lo; s <= hi + mpp / 2; s += mpp / 2) {
      const open = s <= hi && (vertical ? free(fixed, s) : free(s, fixed));
      if (open && start === null) start = s;
      if (!open && start !== null) {
        const width = s - start;
        if (width >= minDoor) {
          const mid = round(snap((start + s) / 2));
          out.push({ at: vertical ? [round(fixed), mid] : [mid, round(fixed)], width: round(snap(width)) });
        }
        start = null;
      }
    }
  };
  for (let i = 0; i < boxes.length; i++) {
    for (let j = i + 1; j < boxes.length; j++) {
      const [a, b] = [boxes[i], boxes[j]];
      const [ylo, yhi] = [Math.max(a[1], b[1]), Math.min(a[3], b[3])];
      const [xlo, xhi] = [Math.max(a[0], b[0]), Math.min(a[2], b[2])];
      for (const x of [a[0], a[2]]) if ((x === b[0] || x === b[2]) && yhi > ylo) runs(x, ylo, yhi, true);
      for (const y of [a[1], a[3]]) if ((y === b[1] || y === b[3]) && xhi > xlo) runs(y, xlo, xhi, false);
    }
  }
  return out;
}
