// What the task says to the user on the panel's message line: every sentence the task
// session shows is worded here, so that session.ts only decides which one and when.

import { PlanTaskResponse } from "../generated/msgs";
import { humanize } from "../ui/dom";
import type { MessageKind } from "./panel";
import type { RunResult } from "./run";

export const ARRANGE = "Arrange the scene, press Set Robot, then Move Robot!";
export const EDITABLE_AGAIN = "The robot and the object can be moved again.";
export const PLANNING = "Planning a path…";
/** The first plan after the server starts also prepares the planner. */
export const STILL_PLANNING =
  "Still planning… the first plan after the server starts can take a minute.";
export const MOVING = "Moving…";
export const SCENE_SAVED = "Scene saved as a file.";
export const SCENE_LOADED = "Scene loaded.";

/** After Set Robot: whether the object is in the hand (null: there is no object). */
export function robotSet(objectHeld: boolean | null): string {
  const object =
    objectHeld === null
      ? ""
      : objectHeld
        ? " The object is in the hand."
        : " The object is not in the hand: it stays where it is.";
  return `Robot set.${object} Press Move Robot! to plan and move.`;
}

export function unreachable(err: unknown): string {
  return `Could not reach the planner: ${errorText(err)}`;
}

export function refused(response: PlanTaskResponse): string {
  return `The planner says no: ${plainReason(response)}`;
}

export function motionFailed(err: unknown): string {
  return `The motion could not run: ${errorText(err)}`;
}

export function sceneNotLoaded(fileName: string, err: unknown): string {
  return `Could not load ${fileName}: ${errorText(err)}`;
}

/** No planner on this server plans for the robot on screen. */
export function noPlanner(robot: string): string {
  return (
    `No planner on this server plans for the ${humanize(robot).toLowerCase()}; ` +
    "it can be arranged but not moved."
  );
}

/** The server's planner is compiling its kernels (once after an install). */
export function plannerCompiling(): string {
  return "The planner is getting ready (compiling, once after an install); Move Robot! may take a while.";
}

/** The message for the end of a run, and whether it is good news. */
export function runSummary(r: RunResult): [string, MessageKind] {
  const length = (m: number) =>
    m < 0.001
      ? "less than 1 mm"
      : m < 0.01
        ? `${(m * 1000).toFixed(1)} mm`
        : `${(m * 100).toFixed(1)} cm`;
  const touched = r.contacts.length
    ? `it touched ${[...new Set(r.contacts.map((c) => c.b))].join(", ")} (${r.contacts
        .map((c) => c.a)
        .join(", ")})`
    : "no contact with obstacles";
  const reached = r.finalError <= 0.01;
  const text =
    `${reached ? "Done" : "Finished"}: the hand is ${length(r.finalError)} from the goal; ` +
    `${touched}; ` +
    `it followed the plan within ${length(r.rmsGap)} (RMS).`;
  return [text, reached && r.contacts.length === 0 ? "ok" : "error"];
}

/** The planner's reason, said plainly from its error code, with the message's details. */
function plainReason(response: PlanTaskResponse): string {
  const plain: Record<number, string> = {
    [PlanTaskResponse.NO_IK_SOLUTION]: "the goal is out of the arm's reach",
    [PlanTaskResponse.START_STATE_IN_COLLISION]: "the robot starts out touching something",
    [PlanTaskResponse.GOAL_IN_COLLISION]:
      "the hand cannot be at the goal without touching something",
    [PlanTaskResponse.TIMED_OUT]: "no way around the obstacles was found in time",
    [PlanTaskResponse.INVALID_MOTION_PLAN]: "no path the robot can follow safely was found",
    [PlanTaskResponse.INVALID_GOAL_CONSTRAINTS]: "the request is not one the planner can take",
  };
  const message = response.message;
  const said = plain[response.error_code];
  if (!said) return message || "no reason given.";
  // The message is "<what>: <details>"; the details say which link, how far, how long.
  const colon = message.indexOf(":");
  const detail = (colon >= 0 ? message.slice(colon + 1) : message).trim().replace(/\.$/, "");
  if (!detail) return `${said}.`;
  return `${said}. ${detail.charAt(0).toUpperCase()}${detail.slice(1)}.`;
}

/** An error's message, or the thrown value as text. */
export function errorText(err: unknown): string {
  return err instanceof Error ? err.message : String(err);
}
