// Keyboard driving: which keys are held -> a velocity command (m/s, rad/s). Arrow keys
// or W A S D: forward, back, turn left, turn right; both directions cancel out.

export interface DriveLimits {
  /** Top forward speed (m/s) and yaw rate (rad/s) of the robot. */
  speed: number;
  yawRate: number;
}

/** Keys as KeyboardEvent.key gives them (letters in lower case). */
export const DRIVE_KEYS = new Set(["ArrowUp", "ArrowDown", "ArrowLeft", "ArrowRight", "w", "a", "s", "d"]);

/** Keyboard driving uses half the robot's top speed and yaw rate: easy to steer. */
const SHARE = 0.5;

export function drive(held: ReadonlySet<string>, limits: DriveLimits): [number, number] {
  const forward = Number(held.has("ArrowUp") || held.has("w")) - Number(held.has("ArrowDown") || held.has("s"));
  const left = Number(held.has("ArrowLeft") || held.has("a")) - Number(held.has("ArrowRight") || held.has("d"));
  return [forward * limits.speed * SHARE, left * limits.yawRate * SHARE];
}
