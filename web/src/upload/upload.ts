// "Your own robot": a panel section that sends a URDF zip (with meshes), a xacro or an
// RDTF file to the server (POST /api/robots/upload) and, once accepted, opens the robot.
// What the server refuses is shown in words: which file, which element, which line.

import { errorText, type RobotEntry, type UploadAnswer } from "../api";
import "./upload.css";
import { pageToken } from "../ros/connection";
import { el, robotTitle } from "../ui/dom";

export const UPLOAD_URL = "/api/robots/upload";
const ACCEPT = ".zip,.urdf,.xacro,.glb";

/** Send `file` to the server; resolves with the new robot's entry, rejects with the
 * server's reason. */
export async function uploadRobot(file: File): Promise<UploadAnswer> {
  const form = new FormData();
  form.append("file", file, file.name);
  let response: Response;
  try {
    const token = pageToken();
    const headers: Record<string, string> = token ? { Authorization: `Bearer ${token}` } : {};
    response = await fetch(UPLOAD_URL, { method: "POST", body: form, headers });
  } catch (err) {
    throw new Error(`could not send ${file.name}: ${err instanceof Error ? err.message : err}`);
  }
  if (!response.ok) {
    const text = await errorText(UPLOAD_URL, response);
    throw new Error(text.replace(`${UPLOAD_URL}: `, ""));
  }
  return (await response.json()) as UploadAnswer;
}

/** Make `link` the tool of the uploaded robot `robot` (POST /api/robots/{name}/tool):
 * resolves with its new entry, rejects with the server's reason. */
export async function chooseTool(robot: string, link: string): Promise<RobotEntry> {
  const url = `/api/robots/${encodeURIComponent(robot)}/tool`;
  const token = pageToken();
  const response = await fetch(url, {
    method: "POST",
    body: JSON.stringify({ link }),
    headers: {
      "Content-Type": "application/json",
      ...(token ? { Authorization: `Bearer ${token}` } : {}),
    },
  });
  if (!response.ok) throw new Error((await errorText(url, response)).replace(`${url}: `, ""));
  return (await response.json()) as RobotEntry;
}

export class UploadSection {
  /** The panel section: the app mounts it (Panel.mount). */
  readonly section: HTMLElement;
  private readonly input = el("input", {
    type: "file",
    id: "robot-upload",
    accept: ACCEPT,
    "aria-label": "Robot file: a zip with a URDF and its meshes, a xacro, or an RDTF .glb",
  });
  private readonly message = el("p", { class: "upload-message", id: "upload-message", role: "status" });

  /** `accepted(entry)`: the app adds the robot to its pickers and opens it. */
  constructor(private readonly accepted: (answer: UploadAnswer) => Promise<void>) {
    this.section = el(
      "section",
      { class: "upload", id: "upload" },
      el("h2", {}, "Your own robot"),
      el(
        "p",
        { class: "hint" },
        "A zip with a URDF (or xacro) and its meshes, a .xacro, or an RDTF .glb.",
      ),
      this.input,
      this.message,
    );
    this.input.addEventListener("change", () => {
      const file = this.input.files?.[0];
      if (file) void this.send(file);
    });
  }

  private async send(file: File): Promise<void> {
    this.show(`Uploading ${file.name}…`, "loading");
    try {
      const answer = await uploadRobot(file);
      await this.accepted(answer);
      const fixed = answer.repairs.length ? ` Repaired: ${answer.repairs.join("; ")}` : "";
      const title = robotTitle(answer.robot);
      this.show(`${file.name} is now “${title}” in the robot list.${fixed}`, "ready");
    } catch (err) {
      this.show(err instanceof Error ? err.message : String(err), "error");
    } finally {
      this.input.value = "";
    }
  }

  private show(text: string, status: "loading" | "ready" | "error"): void {
    this.message.textContent = text;
    this.message.dataset.status = status;
    this.message.setAttribute("role", status === "error" ? "alert" : "status");
    // The section sits low in a long panel: bring what the server said into view.
    if (status !== "loading") this.message.scrollIntoView({ block: "nearest" });
  }
}
