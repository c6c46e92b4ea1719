// The files the task hands to the user, named after the robot and world: the scene (a
// robotrial-scene JSON file, what Load scene reads back) and the hand's path after a
// run, as CSV samples or as the chart in PNG.

import { type Arrangement, sceneFile } from "./arrangement";
import { chartPng, pathCsv, type PathSample } from "./plot";

/** Offer `scene` as `ROBOT-WORLD-scene.json`. */
export function saveSceneFile(scene: Arrangement, robot: string, world: string): void {
  const blob = new Blob([sceneFile(scene)], { type: "application/json" });
  download(blob, `${robot}-${world}-scene.json`);
}

/** Offer the hand's path of `robot` as `ROBOT-hand-path.csv` (the samples) or
 * `ROBOT-hand-path.png` (`chart()` drawn as PNG). */
export async function savePath(
  kind: "csv" | "png",
  robot: string,
  samples: PathSample[],
  chart: () => SVGSVGElement,
): Promise<void> {
  const stem = `${robot}-hand-path`;
  if (kind === "csv") {
    download(new Blob([pathCsv(samples)], { type: "text/csv" }), `${stem}.csv`);
  } else {
    download(await chartPng(chart()), `${stem}.png`);
  }
}

/** Offer `blob` to the user as a file named `name`. */
function download(blob: Blob, name: string): void {
  const url = URL.createObjectURL(blob);
  const a = document.createElement("a");
  a.href = url;
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}
