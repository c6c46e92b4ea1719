// "Check my home": every sentence the verdict view shows, in one place.

export const VERDICT_WORDS = {
  check: "Check my home",
  robot: "Robot",
  compare: "Compare with",
  nobody: "no other robot",
  noRobots: "The server offers no robot that drives, so there is nothing to check with.",
  title: "Will it get around?",
  starting: "Sending the home to the server…",
  progress: (what: string, fraction: number) => `${what} (${Math.round(fraction * 100)} %)`,
  /** The line at the top: one robot's summary, or each robot's after its name. */
  summaries: (pairs: [string, string][]) =>
    pairs.length === 1 ? pairs[0][1] : pairs.map(([robot, line]) => `${robot}: ${line}`).join(" · "),
  failed: (why: string) => `The home could not be checked: ${why}`,
  lost: "The server no longer knows this check (it may have restarted): check again.",
  stale: "The home changed since it was checked: the colours on the plan are hidden until you check again.",
  back: "Back to the lists",
  show: "Show the verdict",
  base: (length: number, width: number, turning: number | null) =>
    `Base ${length.toFixed(2)} × ${width.toFixed(2)} m` +
    (turning === null ? "." : `; turning on the spot needs ${turning.toFixed(2)} m.`),
  legend:
    "Green: reachable, with room to turn on the way. Amber: reachable, but a passage is " +
    "narrower than the turning circle. Red: the base cannot get there.",
  doorLegend:
    "On the plan: each doorway in the colour its width earns (red: narrower than the base, " +
    "amber: narrower than the turning circle), each room in its verdict, the way there as a line.",
  more: "More figures",
  same: "Both robots reach the same rooms, with the same colours.",
  onlyReaches: (robot: string, rooms: string[]) => `Only ${robot} reaches ${rooms.join(", ")}.`,
  colourDiffers: (room: string, a: string, ca: string, b: string, cb: string) =>
    `${room}: ${ca} for ${a}, ${cb} for ${b}.`,
  yes: "yes",
  no: "no",
  none: "–",
  columns: {
    room: "Room",
    colour: "Verdict",
    reachable: "Reachable",
    passage: "Narrowest passage (m)",
    route_length: "Route (m)",
    reason: "Why not",
  } as Record<string, string>,
  /** Figures of the rooms table that a buyer does not need to see. */
  hidden: ["route", "plan_ms"] as readonly string[],
  colours: { green: "green", amber: "amber", red: "red" } as Record<string, string>,
  chores: "Chores",
  choresHint:
    "Carry an object to a room: each chore runs the whole task in simulation (map the home, " +
    "drive, pick, carry, place), about a minute of the server's time per run.",
  choreObject: "Object",
  choreRoom: "to",
  choreAdd: "Add",
  choreRemove: "Remove this chore",
  seeds: "Runs of each",
  chore: (object: string, room: string) => `${object} to ${room}`,
  choreDone: (name: string, ok: number, runs: number, time: number | null) =>
    `${name}: ${ok === runs && runs > 0 ? "done" : "not done"}, ${ok} of ${runs} runs` +
    (time === null ? "." : `, ${time.toFixed(0)} s on average.`),
  choreShares: (shares: Record<string, number>) =>
    "Of that: " +
    Object.entries(shares)
      .map(([what, t]) => `${what} ${t.toFixed(0)} s`)
      .join(", ") +
    ".",
  choreFailure: (seed: number, phase: string, reason: string) =>
    `Run ${seed + 1} stopped in ${phase || "an unknown phase"}: ${reason}.`,
  choreRefused: (name: string, why: string) => `${name}: not tried: ${why}.`,
} as const;
