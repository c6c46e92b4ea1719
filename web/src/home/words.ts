// "My home": every sentence the home editor shows, in one place.

import type { Problem } from "./model";

const m = (v: number): string => `${v.toFixed(2)} m`;

export const WORDS = {
  title: "My home",
  hint: "Draw your rooms, doorways and furniture so the robot can be tried in your home.",
  open: "Draw my home",
  close: "Close editor",
  tools: {
    select: "Select",
    room: "Room",
    door: "Doorway",
    furniture: "Furniture",
    object: "Object",
    spawn: "Robot start",
    scale: "Measure",
  },
  toolHints: {
    select: "Click an item to find it in the list.",
    room: "Click the room's corners; click the first corner again (or Close room) to close it.",
    door: "Click on a wall to put a doorway there.",
    furniture: "Pick a kind of furniture, then click where it stands.",
    object: "Click where an object to fetch lies (on the floor or on furniture).",
    spawn: "Click where the robot starts.",
    scale:
      "Click both ends of a length you know on the floor-plan image, type it in metres, " +
      "then Set scale.",
  },
  background: "Floor-plan image",
  knownLength: "Known length (m)",
  setScale: "Set scale",
  measured: (d: number) => `Marked ${d.toFixed(2)} m at the image's present scale.`,
  markFirst: "Mark both ends of a known length on the image first (Measure tool).",
  scaled: (mpp: number) => `Image scale set: 1 pixel is ${(mpp * 100).toFixed(2)} cm.`,
  notImage: (file: string) =>
    `${file} is not a PNG, JPG or PGM image (or a map's YAML with its image); the drawing is unchanged.`,
  badMap: (file: string, why: string) => `${file} is not a usable map: ${why}. The drawing is unchanged.`,
  mapImageMissing: (file: string, image: string) =>
    `${file} names the image ${image}: choose both files together. The drawing is unchanged.`,
  mapPlaced: (mpp: number) =>
    `Map placed at its own origin and scale: 1 pixel is ${(mpp * 100).toFixed(2)} cm.`,
  findRooms: "Find rooms",
  noImage: "Load a floor-plan image first.",
  found: (rooms: number, doors: number) =>
    `Found ${rooms} room${rooms === 1 ? "" : "s"} and ${doors} doorway${doors === 1 ? "" : "s"} ` +
    "in the image (Undo takes them away).",
  noneFound:
    "No closed room found in the image: walls must be darker than the floor and enclose it; " +
    "set the scale first. Trace the rooms with the Room tool instead.",
  imageNotKept:
    "The image is too large to keep in this browser: it stays until the page is reloaded.",
  closeRoom: "Close room",
  cancelRoom: "Cancel room",
  undo: "Undo",
  redo: "Redo",
  clear: "New home",
  download: "Download YAML",
  openYaml: "Open YAML",
  send: "Send to server",
  doorWidth: "Doorway width (m)",
  preset: "Furniture",
  lists: {
    walls: "Walls",
    rooms: "Rooms",
    doorways: "Doorways",
    furniture: "Furniture",
    objects: "Objects to fetch",
    spawn: "Robot start",
  },
  fields: {
    thickness: "Thickness (m)",
    height: "Height (m)",
    name: "Name",
    edge: (k: number) => `Edge ${k} (m)`,
    width: "Width (m)",
    depth: "Depth (m)",
    diameter: "Diameter (m)",
    size: "Size (m)",
    x: "x (m)",
    y: "y (m)",
    remove: "Remove",
  },
  roomName: (i: number) => `Room ${i}`,
  doorName: (i: number) => `Doorway ${i}`,
  objectName: (i: number) => `object ${i}`,
  nothing: "Nothing yet.",
  spawnAuto: "Not placed: the robot starts in the middle of the first room.",
  ok: "The home is complete.",
  notNumber: (text: string, what: string, kept: string) =>
    `“${text}” is not a number: ${what} keeps ${kept}.`,
  notPositive: (text: string, what: string, kept: string) =>
    `${what} must be more than 0 (got ${text}): it keeps ${kept}.`,
  noWall: "Click on a wall: a doorway goes in a wall of a room.",
  downloaded: (file: string) => `Saved ${file}.`,
  opened: (file: string) => `Opened ${file}.`,
  notAHome: (file: string) =>
    `${file} has no home section, so it cannot be opened here (only homes drawn in this ` +
    "editor can); your drawing is unchanged.",
  badHome: (file: string, why: string) => `${file}: ${why}; your drawing is unchanged.`,
  fixFirst: "Fix these first:",
  sending: "Sending your home to the server…",
  sent: (name: string) => `The server added “${name}” to the world list; the robot is shown in it.`,
  restoreFailed:
    "The home kept in this browser could not be read; it is kept aside (robotrial.home.broken) " +
    "and the editor starts empty.",
  problem(p: Problem): string {
    switch (p.kind) {
      case "open":
        return `${p.item} is not closed: click its first corner (or ${WORDS.closeRoom}) to close it.`;
      case "few":
        return `${p.item} is not closed: a room needs at least 3 corners.`;
      case "crossing":
        return `${p.item}: its edges ${p.a} and ${p.b} cross.`;
      case "empty":
        return "Draw a room first.";
      case "offWall":
        return `${p.item} does not sit on a wall (the nearest is ${m(p.value)} away).`;
      case "narrow":
        return `${p.item} is ${m(p.value)} wide, narrower than the wall is thick (${m(p.limit)}).`;
      case "wide":
        return `${p.item} is ${m(p.value)} wide, wider than its wall (${m(p.limit)}).`;
      case "overlap":
        return `${p.item} overlaps ${p.other}.`;
      case "duplicate":
        return `Two items are called “${p.item}”: names must differ.`;
    }
  },
} as const;
