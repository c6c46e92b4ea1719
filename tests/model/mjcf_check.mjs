// Load an MJCF folder written by robotrial.model.mjcf in the browser's MuJoCo (npm
// mujoco-js, the official WebAssembly build), step it for one second and print a JSON
// report: version, body/actuator counts, whether the state stayed finite.
//
//   MUJOCO_JS=path/to/node_modules/mujoco-js node tests/model/mjcf_check.mjs FOLDER/model.xml
import fs from "node:fs";
import path from "node:path";
import { pathToFileURL } from "node:url";

const xmlPath = process.argv[2];
if (!xmlPath) {
  console.error("usage: node mjcf_check.mjs MODEL.xml");
  process.exit(2);
}
const pkgDir = process.env.MUJOCO_JS || "node_modules/mujoco-js";
const pkg = JSON.parse(fs.readFileSync(path.join(pkgDir, "package.json"), "utf8"));
const { default: loadMujoco } = await import(pathToFileURL(path.resolve(pkgDir, pkg.main)).href);
const mujoco = await loadMujoco();

// Copy the XML and every file beside it (the meshes) into the in-memory file system.
mujoco.FS.mkdir("/working");
mujoco.FS.mount(mujoco.MEMFS, { root: "." }, "/working");
const folder = path.dirname(path.resolve(xmlPath));
for (const name of fs.readdirSync(folder)) {
  const full = path.join(folder, name);
  if (fs.statSync(full).isFile()) mujoco.FS.writeFile(`/working/${name}`, fs.readFileSync(full));
}

const model = mujoco.MjModel.loadFromXML(`/working/${path.basename(xmlPath)}`);
const data = new mujoco.MjData(model);
const steps = Math.round(1.0 / model.opt.timestep);
for (let i = 0; i < steps; i++) mujoco.mj_step(model, data);
const qpos = Array.from(data.qpos);
console.log(
  JSON.stringify({
    version: mujoco.mj_versionString(),
    nbody: model.nbody,
    njnt: model.njnt,
    nu: model.nu,
    nmesh: model.nmesh,
    time: data.time,
    finite: qpos.every(Number.isFinite),
  }),
);
data.delete();
model.delete();
