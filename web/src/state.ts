// window.robotrial: what scripts and tests may read from the page (docs/web.md).

export interface RobotrialState {
  robot: string;
  world: string;
  joints: { names: string[]; values: number[] };
  /** The end effector (tcp) in the robot's base frame (m); null before a robot loads. */
  endEffector: [number, number, number] | null;
  /** True once the robot and world shown match `robot` and `world` and can be moved. */
  ready: boolean;
  /** Why the last load failed, or null. */
  error: string | null;
}

export interface RobotrialApi {
  /** A read-only copy of the page's state; later changes do not show in it. */
  state(): RobotrialState;
}

declare global {
  interface Window {
    robotrial: RobotrialApi;
  }
}

export function installWindowApi(source: () => RobotrialState): void {
  const api: RobotrialApi = { state: () => deepFreeze(structuredClone(source())) };
  Object.defineProperty(window, "robotrial", { value: Object.freeze(api), enumerable: true });
}

function deepFreeze<T>(value: T): T {
  if (value && typeof value === "object") {
    for (const v of Object.values(value)) deepFreeze(v);
    Object.freeze(value);
  }
  return value;
}
