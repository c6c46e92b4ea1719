// The HTTP side of the server: what the page opens on, the built-in robots and worlds,
// and the URLs of their files. Shapes match src/robotrial/app/server.py.

export type Kind = "arm" | "mobile";

export interface Pair {
  robot: string;
  world: string;
}

export interface Config extends Pair {
  /** Path of the rosbridge WebSocket on this server, e.g. "/rosbridge". */
  rosbridge: string;
  rosbridge_enabled: boolean;
  /** The platform the server simulates live (a mobile robot in a room), or null. */
  live?: LiveInfo | null;
}

/** A live platform: which robot in which world, and where its odom and map frames
 * start in the world (the spawn pose). */
export interface LiveInfo extends Pair {
  origin: Spawn;
  /** Why it could not start, or null. */
  error: string | null;
}

export interface RobotEntry {
  name: string;
  kind: Kind;
  joints: number;
  /** The world this robot opens in when picked. */
  world: string;
  /** True for a robot a user uploaded to this server. */
  uploaded?: boolean;
}

export interface Spawn {
  xyz: [number, number, number];
  /** x, y, z, w */
  quat: [number, number, number, number];
}

export interface WorldEntry {
  name: string;
  kind: Kind;
  description: string;
  spawn: Spawn;
}

export interface Catalog {
  default: Pair;
  robots: RobotEntry[];
  worlds: WorldEntry[];
}

async function getJson<T>(path: string): Promise<T> {
  const response = await fetch(path);
  if (!response.ok) throw new Error(await errorText(path, response));
  return (await response.json()) as T;
}

/** The server's reason for a failed request ("detail" in FastAPI errors), with the path. */
export async function errorText(path: string, response: Response): Promise<string> {
  let detail = response.statusText;
  try {
    const body = await response.json();
    if (typeof body?.detail === "string") detail = body.detail;
  } catch {
    // not JSON: keep the status text
  }
  return `${path}: ${response.status} ${detail}`;
}

export function getConfig(): Promise<Config> {
  return getJson<Config>("/api/config");
}

export async function getCatalog(): Promise<Catalog> {
  const [robots, worlds] = await Promise.all([
    getJson<{ default: Pair; robots: RobotEntry[] }>("/api/robots"),
    getJson<{ default: Pair; worlds: WorldEntry[] }>("/api/worlds"),
  ]);
  return { default: robots.default, robots: robots.robots, worlds: worlds.worlds };
}

export function robotFileUrl(name: string): string {
  return `/api/robots/${encodeURIComponent(name)}.glb`;
}

export function worldFileUrl(name: string): string {
  return `/api/worlds/${encodeURIComponent(name)}.glb`;
}
