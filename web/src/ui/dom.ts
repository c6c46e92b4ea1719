// Small DOM helpers for the panel: build elements, turn identifiers into labels.

type Attributes = Record<string, string>;

/** An element with attributes and children, e.g. el("label", { for: "x" }, "Name"). */
export function el<K extends keyof HTMLElementTagNameMap>(
  tag: K,
  attributes: Attributes = {},
  ...children: Array<Node | string>
): HTMLElementTagNameMap[K] {
  const node = document.createElement(tag);
  for (const [name, value] of Object.entries(attributes)) node.setAttribute(name, value);
  node.append(...children);
  return node;
}

/** "mobile_manipulator" -> "Mobile manipulator", "room_a" -> "Room A", "joint2" -> "Joint 2". */
export function humanize(identifier: string): string {
  const words = identifier
    .replace(/([a-z])([0-9])/g, "$1 $2")
    .split(/[_\s-]+/)
    .filter(Boolean)
    .map((w) => (w.length === 1 ? w.toUpperCase() : w.toLowerCase()));
  const text = words.join(" ");
  return text.charAt(0).toUpperCase() + text.slice(1);
}

/** A robot's name for people: as its description writes it for a robot someone brought
 * (an upload, a file), else the built-in's identifier made readable. */
export function robotTitle(robot: { name: string; title?: string; uploaded?: boolean }): string {
  return robot.uploaded && robot.title ? robot.title : humanize(robot.name);
}
