// "Check my home": the home as drawn goes to the server (POST /api/verdict) with one robot
// or two; a progress bar follows the check (GET /api/verdict/{id}) and then the verdict
// shows beside the plan: the summary, the server's pictures, a table of the rooms in
// their colours, two robots in two columns with their differences marked. The drawing
// itself is not touched (the editor keeps it in localStorage). Chores picked beside the
// button ("carry this object to that room") go with the home and run on the server as
// carry trials; each chore's result shows under the robot's rooms. The view renders what the
// server sends generically (any pictures, any figures per room), so a richer verdict
// needs no change here.

import { errorText, getCatalog, type RobotEntry } from "../api";
import type { ChoreRequest, RobotVerdict, VerdictJob } from "../generated/api";
import { pageToken } from "../ros/connection";
import { el, humanize } from "../ui/dom";
import { bodyName, type Home, type XY } from "./model";
import "./verdict.css";
import { VERDICT_WORDS as W } from "./verdict_words";

export const VERDICT_URL = "/api/verdict";
/** How often (ms) the page asks how a check is going. */
const POLL_MS = 300;
const PREFERRED_ROBOT = "mobile_manipulator";
/** The most chores, and runs of each, one check takes (the server's limits). */
const MAX_CHORES = 5;
const MAX_SEEDS = 5;

export type Colour = "green" | "amber" | "red";

/** What the editor's plan shows of a verdict: rooms by name, doorways by index, routes. */
export interface PlanColours {
  rooms: Map<string, Colour>;
  doors: (Colour | null)[];
  routes: { colour: Colour; points: XY[] }[];
}

function colourOf(value: unknown): Colour | null {
  return value === "green" || value === "amber" || value === "red" ? value : null;
}

/** Start checking `world` (a name or its YAML) for `robots`, with `chores` run `seeds`
 * times each; resolves with the new job. */
export async function startVerdict(
  world: string,
  robots: string[],
  chores: ChoreRequest[] = [],
  seeds = 1,
): Promise<VerdictJob> {
  const token = pageToken();
  const headers: Record<string, string> = { "Content-Type": "application/json" };
  if (token) headers.Authorization = `Bearer ${token}`;
  const response = await fetch(VERDICT_URL, {
    method: "POST",
    body: JSON.stringify({ world, robots, chores, seeds }),
    headers,
  });
  if (!response.ok) {
    throw new Error((await errorText(VERDICT_URL, response)).replace(`${VERDICT_URL}: `, ""));
  }
  return (await response.json()) as VerdictJob;
}

/** How the check `id` is going; null when the server does not know it (any more). */
export async function readVerdict(id: string): Promise<VerdictJob | null> {
  const path = `${VERDICT_URL}/${encodeURIComponent(id)}`;
  const response = await fetch(path);
  if (response.status === 404) return null;
  if (!response.ok) throw new Error(await errorText(path, response));
  return (await response.json()) as VerdictJob;
}

/** A doorway's colour for a robot: red when narrower than the base, amber when narrower
 * than the circle it turns in, else green; null when the verdict gives no base size. */
export function doorColour(width: number, verdict: RobotVerdict): Colour | null {
  if (!verdict.footprint) return null;
  if (width < verdict.footprint[1]) return "red";
  if (verdict.turning_diameter !== null && width < verdict.turning_diameter) return "amber";
  return "green";
}

/** One cell of the rooms table, as text. */
function cellText(value: unknown): string {
  if (value === null || value === undefined || value === "") return W.none;
  if (typeof value === "boolean") return value ? W.yes : W.no;
  if (typeof value === "number") return value.toFixed(2);
  if (typeof value === "string") return W.colours[value] ?? value;
  return JSON.stringify(value);
}

/** What differs between two robots' rooms: sentences, and the rooms that differ. */
function differences(a: RobotVerdict, b: RobotVerdict): { lines: string[]; rooms: Set<string> } {
  const byName = (v: RobotVerdict) => new Map(v.rooms.map((r) => [String(r.room), r]));
  const ra = byName(a);
  const rb = byName(b);
  const onlyA: string[] = [];
  const onlyB: string[] = [];
  const lines: string[] = [];
  const rooms = new Set<string>();
  for (const [name, x] of ra) {
    const y = rb.get(name);
    if (!y) continue;
    if (x.reachable && !y.reachable) onlyA.push(name);
    else if (!x.reachable && y.reachable) onlyB.push(name);
    else if (x.colour !== y.colour) {
      const [na, nb] = [humanize(a.robot), humanize(b.robot)];
      lines.push(W.colourDiffers(name, na, cellText(x.colour), nb, cellText(y.colour)));
    } else continue;
    rooms.add(name);
  }
  if (onlyA.length) lines.unshift(W.onlyReaches(humanize(a.robot), onlyA));
  if (onlyB.length) lines.unshift(W.onlyReaches(humanize(b.robot), onlyB));
  return { lines: lines.length ? lines : [W.same], rooms };
}

/** One chore's result as a sentence: done x of n, the time and where it went (exploring,
 * navigating, searching, manipulating), or where and why it failed. */
export function choreText(c: Record<string, unknown>): string {
  const name = W.chore(String(c.object ?? ""), String(c.room ?? ""));
  if (c.refused) return W.choreRefused(name, String(c.refused));
  const runs = Number(c.runs ?? 0);
  const ok = Number(c.successes ?? 0);
  const time = typeof c.mean_time === "number" ? c.mean_time : null;
  const failures = (Array.isArray(c.outcomes) ? c.outcomes : [])
    .map((o) => o as Record<string, unknown>)
    .filter((o) => !o.success)
    .map((o) => W.choreFailure(Number(o.seed), String(o.failed_phase ?? ""), String(o.reason ?? "")));
  const shares = c.shares && typeof c.shares === "object" ? (c.shares as Record<string, number>) : null;
  const parts = shares ? [W.choreShares(shares)] : [];
  return [W.choreDone(name, ok, runs, time), ...parts, ...failures].join(" ");
}

/** The parts the editor lends the view. */
export interface VerdictHost {
  /** The home's YAML, or null (the editor then says what to fix). */
  yaml(): string | null;
  /** The home as drawn now. */
  home(): Home;
  /** A verdict arrived or was put aside: redraw the plan. */
  changed(): void;
}

export class VerdictView {
  /** The robot pickers and the button: the editor puts them in its toolbar. */
  readonly controls: HTMLElement;
  /** The progress bar and the verdict: the editor puts it beside the plan. */
  readonly section: HTMLElement;
  private readonly robot = el("select", { id: "verdict-robot" });
  private readonly compare = el("select", { id: "verdict-compare" });
  private readonly button = el("button", { type: "button", id: "home-check" }, W.check);
  private readonly bar = el("progress", { id: "verdict-progress", max: "1", value: "0" });
  private readonly what = el("p", { id: "verdict-what", role: "status" });
  private readonly stale = el("p", { id: "verdict-stale", class: "hint", hidden: "" }, W.stale);
  private readonly body = el("div", { id: "verdict-body" });
  private readonly choreObject = el("select", { id: "chore-object" });
  private readonly choreRoom = el("select", { id: "chore-room" });
  private readonly choreAdd = el("button", { type: "button", id: "chore-add" }, W.choreAdd);
  private readonly choreList = el("ul", { id: "chore-list" });
  private readonly seeds = el("input", {
    id: "chore-seeds",
    type: "number",
    min: "1",
    max: String(MAX_SEEDS),
    value: "1",
  });
  /** The chores picked, as the server names them (objects as body names). */
  private chores: ChoreRequest[] = [];
  private robots: RobotEntry[] = [];
  /** The home as checked (JSON) and the answer, for the plan's colours. */
  private checked: { home: string; job: VerdictJob } | null = null;
  /** Counts checks, so that an older one still polling stops when a newer starts. */
  private runs = 0;

  constructor(private readonly host: VerdictHost) {
    this.controls = el(
      "span",
      { class: "verdict-controls" },
      el("label", {}, W.robot, " ", this.robot),
      el("label", {}, W.compare, " ", this.compare),
      el(
        "details",
        { id: "chores", class: "verdict-chores" },
        el("summary", {}, W.chores),
        el("p", { class: "hint" }, W.choresHint),
        el("label", {}, W.choreObject, " ", this.choreObject),
        el("label", {}, W.choreRoom, " ", this.choreRoom),
        this.choreAdd,
        this.choreList,
        el("label", {}, W.seeds, " ", this.seeds),
      ),
      this.button,
    );
    this.button.addEventListener("click", () => void this.check());
    this.choreAdd.addEventListener("click", () => {
      const chore = { object: this.choreObject.value, to: this.choreRoom.value };
      if (!chore.object || !chore.to || this.chores.length >= MAX_CHORES) return;
      if (this.chores.some((c) => c.object === chore.object && c.to === chore.to)) return;
      this.chores.push(chore);
      this.syncChores(this.host.home());
    });
    const back = el("button", { type: "button", id: "verdict-hide" }, W.back);
    back.addEventListener("click", () => {
      this.section.hidden = true;
    });
    this.section = el(
      "section",
      { id: "verdict", class: "verdict", "data-state": "idle", hidden: "" },
      el("div", { class: "verdict-head" }, el("h3", {}, W.title), back),
      el("div", { class: "verdict-progress" }, this.bar, this.what),
      this.stale,
      this.body,
    );
  }

  /** Fill the robot pickers from the server (the robots that drive). */
  async loadRobots(): Promise<void> {
    try {
      const catalog = await getCatalog();
      this.robots = catalog.robots.filter((r) => r.kind === "mobile");
    } catch (err) {
      this.say(err instanceof Error ? err.message : String(err), "failed");
      return;
    }
    const keep = [this.robot.value, this.compare.value];
    const option = (r: RobotEntry) => el("option", { value: r.name }, humanize(r.name));
    this.robot.replaceChildren(...this.robots.map(option));
    this.compare.replaceChildren(el("option", { value: "" }, W.nobody), ...this.robots.map(option));
    const names = this.robots.map((r) => r.name);
    const first = names.includes(PREFERRED_ROBOT) ? PREFERRED_ROBOT : (names[0] ?? "");
    this.robot.value = names.includes(keep[0]) ? keep[0] : first;
    this.compare.value = names.includes(keep[1]) ? keep[1] : "";
    this.button.disabled = !this.robots.length;
    if (!this.robots.length) this.say(W.noRobots, "failed");
  }

  /** The plan's colours from the first robot's verdict; null when there is none or the
   * home has changed since it was checked. */
  planColours(home: Home): PlanColours | null {
    this.syncChores(home);
    const current = this.checked && JSON.stringify(home) === this.checked.home;
    this.stale.hidden = !this.checked || Boolean(current);
    const first = this.checked?.job.results[0];
    if (!current || !first) return null;
    const rooms = new Map<string, Colour>();
    const routes: PlanColours["routes"] = [];
    for (const row of first.rooms) {
      const colour = colourOf(row.colour);
      if (!colour) continue;
      rooms.set(String(row.room), colour);
      if (Array.isArray(row.route)) routes.push({ colour, points: row.route as XY[] });
    }
    return { rooms, doors: home.doorways.map((d) => doorColour(d.width, first)), routes };
  }

  /** The chore pickers offer the home's objects and rooms as drawn now; chores naming
   * one no longer there are dropped. */
  private syncChores(home: Home): void {
    const objects = home.objects.map((o) => bodyName(o.name));
    const label = new Map(home.objects.map((o) => [bodyName(o.name), o.name]));
    const rooms = home.rooms.map((r) => r.name);
    const fill = (select: HTMLSelectElement, names: string[], labels: string[]) => {
      const keep = select.value;
      const same =
        select.options.length === names.length && names.every((n, i) => select.options[i].value === n);
      if (!same) select.replaceChildren(...names.map((n, i) => el("option", { value: n }, labels[i])));
      if (names.includes(keep)) select.value = keep;
    };
    fill(this.choreObject, objects, home.objects.map((o) => o.name));
    fill(this.choreRoom, rooms, rooms);
    this.chores = this.chores.filter((c) => objects.includes(c.object) && rooms.includes(c.to));
    this.choreAdd.disabled = !objects.length || !rooms.length || this.chores.length >= MAX_CHORES;
    this.choreList.replaceChildren(
      ...this.chores.map((c, i) => {
        const remove = el("button", { type: "button", class: "chore-remove", title: W.choreRemove }, "×");
        remove.addEventListener("click", () => {
          this.chores.splice(i, 1);
          this.syncChores(this.host.home());
        });
        const name = W.chore(label.get(c.object) ?? c.object, c.to);
        return el("li", { "data-chore": `${c.object}:${c.to}` }, name, " ", remove);
      }),
    );
  }

  private say(text: string, state: "running" | "failed" | "done"): void {
    this.what.textContent = text;
    this.section.dataset.state = state;
    this.what.setAttribute("role", state === "failed" ? "alert" : "status");
  }

  private async check(): Promise<void> {
    const yaml = this.host.yaml();
    if (yaml === null) return;
    const picked = [this.robot.value, this.compare.value];
    const robots = picked.filter((r, i) => r && picked.indexOf(r) === i);
    if (!robots.length) return;
    const run = ++this.runs;
    const home = JSON.stringify(this.host.home());
    this.section.hidden = false;
    this.body.replaceChildren();
    this.bar.value = 0;
    this.bar.hidden = false;
    this.say(W.starting, "running");
    this.button.disabled = true;
    try {
      const seeds = Math.min(MAX_SEEDS, Math.max(1, Math.round(Number(this.seeds.value) || 1)));
      let job: VerdictJob | null = await startVerdict(yaml, robots, [...this.chores], seeds);
      while (job && job.state !== "done" && job.state !== "failed") {
        if (run !== this.runs) return;
        this.bar.value = job.fraction;
        this.what.textContent = W.progress(job.what, job.fraction);
        await new Promise((resolve) => setTimeout(resolve, POLL_MS));
        job = await readVerdict(job.id);
      }
      if (run !== this.runs) return;
      if (!job) throw new Error(W.lost);
      if (job.state === "failed") throw new Error(job.error ?? job.what);
      this.bar.value = 1;
      this.bar.hidden = true;
      this.checked = { home, job };
      this.show(job);
      this.say(W.summaries(job.results.map((r) => [humanize(r.robot), r.summary])), "done");
    } catch (err) {
      if (run !== this.runs) return;
      this.bar.hidden = true;
      this.say(W.failed(err instanceof Error ? err.message : String(err)), "failed");
    } finally {
      if (run === this.runs) this.button.disabled = !this.robots.length;
      this.host.changed();
    }
  }

  private show(job: VerdictJob): void {
    const [a, b] = job.results;
    const diff = a && b ? differences(a, b) : null;
    const columns = el("div", { id: "verdict-columns", class: `verdict-columns n${job.results.length}` });
    for (const result of job.results) columns.append(this.column(result, diff?.rooms ?? new Set()));
    this.body.replaceChildren(
      ...(diff ? [el("ul", { id: "verdict-differences" }, ...diff.lines.map((l) => el("li", {}, l)))] : []),
      el("p", { class: "hint" }, W.legend, " ", W.doorLegend),
      columns,
    );
    this.section.scrollIntoView({ block: "nearest" });
  }

  private column(v: RobotVerdict, differ: Set<string>): HTMLElement {
    // The table's columns: every plain figure some room has (none for nested ones).
    const keys: string[] = [];
    for (const row of v.rooms) {
      for (const [k, value] of Object.entries(row)) {
        const plain = typeof value !== "object" && value !== "";
        if (plain && !keys.includes(k) && !W.hidden.includes(k)) keys.push(k);
      }
    }
    const head = el("tr", {}, ...keys.map((k) => el("th", {}, W.columns[k] ?? humanize(k))));
    const rows = v.rooms.map((row) => {
      const colour = colourOf(row.colour);
      const room = String(row.room ?? "");
      const tr = el("tr", { "data-room": room, "data-colour": colour ?? "" });
      if (differ.has(room)) tr.classList.add("differs");
      for (const k of keys) {
        const text = cellText(row[k]);
        const td = el("td", {}, text);
        if (text.length > 24) td.classList.add("long");
        if (k === "colour" && colour) td.classList.add(`verdict-${colour}`);
        tr.append(td);
      }
      return tr;
    });
    const figures = Object.entries(v.details).filter(
      ([, value]) => value === null || typeof value !== "object" || Array.isArray(value),
    );
    return el(
      "div",
      { class: "verdict-column", "data-robot": v.robot },
      el("h4", {}, humanize(v.robot)),
      el("p", { class: "verdict-summary" }, v.summary),
      ...(v.footprint
        ? [el("p", { class: "hint" }, W.base(v.footprint[0], v.footprint[1], v.turning_diameter))]
        : []),
      el("table", { class: "verdict-rooms" }, el("thead", {}, head), el("tbody", {}, ...rows)),
      ...(v.chores.length
        ? [
            el("h5", {}, W.chores),
            el(
              "ul",
              { class: "verdict-chore-results" },
              ...v.chores.map((c) =>
                el(
                  "li",
                  { "data-chore": String(c.chore ?? ""), "data-done": c.done ? "yes" : "no" },
                  choreText(c),
                ),
              ),
            ),
          ]
        : []),
      ...Object.entries(v.pictures).map(([title, url]) =>
        el(
          "figure",
          {},
          el("img", { class: "verdict-picture", alt: title, src: url }),
          el("figcaption", {}, title),
        ),
      ),
      el(
        "details",
        {},
        el("summary", {}, W.more),
        el(
          "dl",
          {},
          ...figures.flatMap(([k, value]) => [el("dt", {}, humanize(k)), el("dd", {}, cellText(value))]),
        ),
      ),
    );
  }
}
