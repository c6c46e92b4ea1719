// The live view's status line: the navigation node's NavStatus in words.

import type { NavStatus } from "../generated/msgs";

function seconds(s: number): string {
  return s < 10 ? `${s.toFixed(1)} s` : `${Math.round(s)} s`;
}

function metres(m: number): string {
  return `${m.toFixed(m < 10 ? 2 : 1)} m`;
}

function capital(text: string): string {
  return text.charAt(0).toUpperCase() + text.slice(1);
}

/** One line for the panel: what the navigator does, how far it has left, for how long
 * it has been at it; a refusal or a failure with its reason. */
export function statusLine(s: NavStatus): string {
  const left = s.distance_remaining >= 0 ? `${metres(s.distance_remaining)} to go` : "";
  const took = `${seconds(s.elapsed)} so far`;
  const progress = [left, took].filter(Boolean).join(", ");
  switch (s.state) {
    case "planning":
      return s.text ? `Planning: ${s.text}.` : "Planning a path…";
    case "driving":
      return s.text ? `Driving (${s.text}): ${progress}.` : `Driving: ${progress}.`;
    case "recovering":
      return `Recovering (${s.text}): ${progress}.`;
    case "reached": {
      // the navigator says "reached the goal (0.06 m, 0.12 rad off)"
      const how = s.text.replace(/^reached the goal\s*/, "");
      return `Reached the goal in ${seconds(s.elapsed)}${how ? ` ${how}` : ""}.`;
    }
    case "failed":
      return `Failed after ${seconds(s.elapsed)}: ${s.text}.`;
    case "refused":
      return `Goal refused: ${s.text}.`;
    default:
      return s.text ? capital(s.text) : "Waiting for a goal.";
  }
}
