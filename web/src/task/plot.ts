// The hand's path in the browser's simulation against the path the server planned (the
// g2rViewer paper's Figs. 12 and 13): x, y and z over time, and a view from above with
// the obstacles and the goal. Drawn as SVG; turned into CSV and PNG for exports.ts.

import type { Vec3 } from "../types";
import { quatYaw, type TaskBox } from "./arrangement";

/** One sample of a run: time since the motion began (s) and both hand positions (m). */
export interface PathSample {
  t: number;
  planned: Vec3;
  simulated: Vec3;
}

export interface PlotInput {
  samples: PathSample[];
  obstacles: TaskBox[];
  goal: Vec3;
}

const SVG = "http://www.w3.org/2000/svg";
const WIDTH = 640;
const HEIGHT = 280;
const PLANNED = "#386fd1";
const SIMULATED = "#e0a100";
const AXES = ["x", "y", "z"] as const;

/** The chart as an SVG element (self-contained: it can be saved or drawn to a canvas). */
export function pathChart(input: PlotInput): SVGSVGElement {
  const svg = node("svg", {
    xmlns: SVG,
    viewBox: `0 0 ${WIDTH} ${HEIGHT}`,
    width: String(WIDTH),
    height: String(HEIGHT),
    role: "img",
    "aria-label": "Hand path: planned by the server and simulated in the browser",
    "font-family": "system-ui, sans-serif",
    "font-size": "11",
  });
  svg.append(
    node("rect", { x: "0", y: "0", width: String(WIDTH), height: String(HEIGHT), fill: "#fff" }),
  );
  const { samples } = input;
  const tMax = Math.max(1e-3, ...samples.map((s) => s.t));

  // Left: x, y, z over time, one strip each, in cm.
  const left = { x: 44, w: 300, top: 14, h: 62, gap: 18 };
  AXES.forEach((axis, i) => {
    const y0 = left.top + i * (left.h + left.gap);
    const values = samples.flatMap((s) => [s.planned[i], s.simulated[i]]);
    const lo = Math.min(...values, input.goal[i]);
    const hi = Math.max(...values, input.goal[i]);
    const pad = Math.max(0.01, (hi - lo) * 0.1);
    const sx = (t: number) => left.x + (t / tMax) * left.w;
    const sy = (v: number) => y0 + left.h - ((v - (lo - pad)) / (hi - lo + 2 * pad)) * left.h;
    svg.append(
      node("rect", {
        x: String(left.x),
        y: String(y0),
        width: String(left.w),
        height: String(left.h),
        fill: "#f6f8fa",
        stroke: "#dfe4ea",
      }),
      text(left.x - 6, y0 + left.h / 2 + 4, `${axis}`, "end", "#5f6b7a", "600"),
      text(left.x - 6, y0 + 9, `${((hi + pad) * 100).toFixed(0)}`, "end", "#8a94a3"),
      text(left.x - 6, y0 + left.h, `${((lo - pad) * 100).toFixed(0)}`, "end", "#8a94a3"),
      polyline(
        samples.map((s) => [sx(s.t), sy(s.simulated[i])]),
        SIMULATED,
        "",
        3,
      ),
      polyline(
        samples.map((s) => [sx(s.t), sy(s.planned[i])]),
        PLANNED,
        "5 3",
      ),
    );
  });
  const bottom = left.top + 3 * left.h + 2 * left.gap;
  svg.append(
    text(left.x, bottom + 14, "0 s", "start", "#8a94a3"),
    text(left.x + left.w, bottom + 14, `${tMax.toFixed(1)} s`, "end", "#8a94a3"),
    text(left.x + left.w / 2, bottom + 14, "time · positions in cm", "middle", "#8a94a3"),
  );

  // Right: the view from above (x to the right, y up), equal scales.
  const right = { x: 380, y: 14, size: 220 };
  const points = samples.flatMap((s) => [s.planned, s.simulated]);
  const xs = [...points.map((p) => p[0]), input.goal[0], 0];
  const ys = [...points.map((p) => p[1]), input.goal[1], 0];
  for (const b of input.obstacles) {
    const r = Math.hypot(b.size[0], b.size[1]) / 2;
    xs.push(b.position[0] - r, b.position[0] + r);
    ys.push(b.position[1] - r, b.position[1] + r);
  }
  const span =
    Math.max(Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys), 0.1) * 1.15;
  const cx = (Math.max(...xs) + Math.min(...xs)) / 2;
  const cy = (Math.max(...ys) + Math.min(...ys)) / 2;
  const px = (x: number) => right.x + right.size / 2 + ((x - cx) / span) * right.size;
  const py = (y: number) => right.y + right.size / 2 - ((y - cy) / span) * right.size;
  const scale = right.size / span;
  svg.append(
    node("rect", {
      x: String(right.x),
      y: String(right.y),
      width: String(right.size),
      height: String(right.size),
      fill: "#f6f8fa",
      stroke: "#dfe4ea",
    }),
  );
  for (const b of input.obstacles) {
    const deg = (-quatYaw(b.quaternion) * 180) / Math.PI;
    const [w, d] = [b.size[0] * scale, b.size[1] * scale];
    svg.append(
      node("rect", {
        x: String(-w / 2),
        y: String(-d / 2),
        width: String(w),
        height: String(d),
        fill: "#e07b39",
        "fill-opacity": "0.45",
        stroke: "#b35a22",
        transform: `translate(${px(b.position[0])} ${py(b.position[1])}) rotate(${deg})`,
      }),
    );
  }
  svg.append(
    node("circle", { cx: String(px(0)), cy: String(py(0)), r: "5", fill: "#3e4a59" }),
    text(px(0) + 8, py(0) + 4, "base", "start", "#5f6b7a"),
    polyline(
      samples.map((s) => [px(s.simulated[0]), py(s.simulated[1])]),
      SIMULATED,
      "",
      3,
    ),
    polyline(
      samples.map((s) => [px(s.planned[0]), py(s.planned[1])]),
      PLANNED,
      "5 3",
    ),
    node("circle", {
      cx: String(px(input.goal[0])),
      cy: String(py(input.goal[1])),
      r: "5",
      fill: "none",
      stroke: "#d1384a",
      "stroke-width": "2",
    }),
    text(
      right.x + right.size / 2,
      right.y + right.size + 14,
      "from above (x →, y ↑)",
      "middle",
      "#8a94a3",
    ),
  );

  // Legend.
  const ly = HEIGHT - 6;
  svg.append(
    polyline(
      [
        [left.x, ly - 4],
        [left.x + 22, ly - 4],
      ],
      PLANNED,
      "5 3",
    ),
    text(left.x + 27, ly, "planned by the server", "start", "#3e4a59"),
    polyline(
      [
        [left.x + 170, ly - 4],
        [left.x + 192, ly - 4],
      ],
      SIMULATED,
      "",
      3,
    ),
    text(left.x + 197, ly, "simulated in the browser", "start", "#3e4a59"),
  );
  return svg;
}

/** The chart as an image element for the page. (An inline SVG over the WebGL view left
 * a stale rectangle in the view in Chromium with software rendering; an image does not.) */
export function chartImage(svg: SVGSVGElement): HTMLImageElement {
  const image = new Image(WIDTH, HEIGHT);
  image.alt = svg.getAttribute("aria-label") ?? "";
  image.src = `data:image/svg+xml;charset=utf-8,${encodeURIComponent(
    new XMLSerializer().serializeToString(svg),
  )}`;
  return image;
}

/** The samples as CSV text: time, planned x y z, browser x y z (s, m). */
export function pathCsv(samples: PathSample[]): string {
  const rows = samples.map((s) =>
    [s.t, ...s.planned, ...s.simulated].map((v) => v.toFixed(6)).join(","),
  );
  return (
    ["t,planned_x,planned_y,planned_z,browser_x,browser_y,browser_z", ...rows].join("\n") + "\n"
  );
}

/** The chart drawn as PNG (twice its size, for sharp print). */
export async function chartPng(svg: SVGSVGElement): Promise<Blob> {
  const source = new XMLSerializer().serializeToString(svg);
  const url = URL.createObjectURL(new Blob([source], { type: "image/svg+xml" }));
  try {
    const image = new Image();
    image.src = url;
    await image.decode();
    const canvas = document.createElement("canvas");
    canvas.width = WIDTH * 2;
    canvas.height = HEIGHT * 2;
    const ctx = canvas.getContext("2d");
    if (!ctx) throw new Error("this browser cannot draw to a canvas");
    ctx.scale(2, 2);
    ctx.drawImage(image, 0, 0, WIDTH, HEIGHT);
    return await new Promise((resolve, reject) =>
      canvas.toBlob(
        (b) => (b ? resolve(b) : reject(new Error("could not encode the PNG"))),
        "image/png",
      ),
    );
  } finally {
    URL.revokeObjectURL(url);
  }
}

function node(tag: string, attributes: Record<string, string>): SVGElement & SVGSVGElement {
  const e = document.createElementNS(SVG, tag) as SVGElement & SVGSVGElement;
  for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, v);
  return e;
}

function text(
  x: number,
  y: number,
  content: string,
  anchor: string,
  fill: string,
  weight = "400",
): SVGElement {
  const t = node("text", {
    x: String(x),
    y: String(y),
    "text-anchor": anchor,
    fill,
    "font-weight": weight,
  });
  t.textContent = content;
  return t;
}

function polyline(points: number[][], stroke: string, dash = "", width = 1.6): SVGElement {
  const attrs: Record<string, string> = {
    points: points.map(([x, y]) => `${x.toFixed(1)},${y.toFixed(1)}`).join(" "),
    fill: "none",
    stroke,
    "stroke-width": String(width),
    "stroke-linejoin": "round",
  };
  if (dash) attrs["stroke-dasharray"] = dash;
  return node("polyline", attrs);
}
