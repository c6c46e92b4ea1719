// AR measuring: every sentence the Measure mode shows over the camera image, in one place.

const m = (v: number): string => `${v.toFixed(2)} m`;

export const MEASURE_WORDS = {
  start: "Measure",
  stop: "Done measuring",
  doorway: "Doorway",
  counter: "Counter edge",
  table: "Table edge",
  discard: "Measure again",
  length: (v: number) => m(v),
  first:
    "Aim at one end (a door frame's side, a counter's edge) and tap. Your home's plan " +
    "puts the robot here at its start, facing the plan's x axis.",
  second: "Aim at the other end and tap.",
  choose: (length: number) => `${m(length)}. What is it?`,
  noHit: "No surface where you aim: point at a floor, wall or table and tap again. The first point stays.",
  tooShort: (length: number, least: number) =>
    `The two points are ${m(length)} apart, less than ${m(least)}: this measure is refused. ` +
    "Aim at the other end and tap again.",
  onFloor: (height: number) =>
    `That edge is ${m(height)} above the floor the robot stands on: a counter or table edge is higher. ` +
    "Nothing was added; measure the edge itself.",
  doorOnWall: (name: string, width: number, room: string) =>
    `${name}, ${m(width)} wide, added to your home in a wall of ${room}.`,
  doorListed: (name: string, width: number) =>
    `${name}, ${m(width)} wide, added to your home's doorways; no wall is drawn there, ` +
    "so move it onto one in My home.",
  furniture: (name: string, length: number, height: number) =>
    `${name} added to your home: ${m(length)} long, ${m(height)} high.`,
  placeFirst: "Place the robot first: measurements are laid out from where it stands.",
} as const;
