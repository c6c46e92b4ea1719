// The HTTP side of the server: what the page opens on, the built-in robots and worlds,
// the URLs of their files, and the MuJoCo model for the browser's physics. The types of
// the answers are generated from the server's models (robotrial.app.models) into
// generated/api.ts; this module only fetches.

import type { Config, MjcfBundle, RobotList, WorldList } from "./generated/api";

export type {
  Config,
  LiveInfo,
  MjcfBundle,
  Pair,
  RobotEntry,
  SpawnPose,
  UploadAnswer,
  WorldEntry,
} from "./generated/api";

/** The robots and the worlds together, as the pickers use them. Written here, not
 * generated: no route answers with it, the page joins /api/robots and /api/worlds. */
export interface Catalog extends RobotList, WorldList {}

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
    getJson<RobotList>("/api/robots"),
    getJson<WorldList>("/api/worlds"),
  ]);
  return { default: robots.default, robots: robots.robots, worlds: worlds.worlds };
}

/** The server's MJCF for `robot` in `world`, for the browser's physics. */
export function fetchMjcf(robot: string, world: string): Promise<MjcfBundle> {
  const name = encodeURIComponent(robot);
  return getJson<MjcfBundle>(`/api/robots/${name}/mjcf.json?world=${encodeURIComponent(world)}`);
}

export function robotFileUrl(name: string): string {
  return `/api/robots/${encodeURIComponent(name)}.glb`;
}

export function worldFileUrl(name: string): string {
  return `/api/worlds/${encodeURIComponent(name)}.glb`;
}
