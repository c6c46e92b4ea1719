// Load MJCF folders written by robotrial.model.mjcf in the browser's MuJoCo (npm
// mujoco-js, the official WebAssembly build), step each for one second and print one JSON
// line per model: version, body/joint/actuator/mesh counts, whether the state stayed finite.
//
//   MUJOCO_JS=web/node_modules/mujoco-js node tests/model/mjcf_check.mjs A/model.xml [B/model.xml ...]
import fs from "node:fs";
import path from "node:path";
import { pathToFileURL } from "node:url";

const xmlPaths = process.argv.slice(2);
if (xmlPaths.length === 0) {
  console.error("usage: node mjcf_check.mjs MODEL.xml [MODEL.xml ...]");
  process.exit(2);
}
const pkgDir = process.env.MUJOCO_JS || "node_modules/mujoco-js";
const pkg = JSON.parse(fs.readFileSync(path.join(pkgDir, "package.json"), "utf8"));
const { default: loadMujoco } = await import(pathToFileURL(path.resolve(pkgDir, pkg.main)).href);
const mujoco = await loadMujoco();

mujoco.FS.mkdir("/working");
mujoco.FS.mount(mujoco.MEMFS, { root: "." }, "/working");
let failed = false;
for (const [index, xmlPath] of xmlPaths.entries()) {
  // Copy the XML and every file beside it (the meshes) into the in-memory file system.
  const dir = `/working/${index}`;
  mujoco.FS.mkdir(dir);
  const folder = path.dirname(path.resolve(xmlPath));
  for (const name of fs.readdirSync(folder)) {
    const full = path.join(folder, name);
    if (fs.statSync(full).isFile()) mujoco.FS.writeFile(`${dir}/${name}`, fs.readFileSync(full));
  }
  let model;
  let data;
  try {
    model = mujoco.MjModel.loadFromXML(`${dir}/${path.basename(xmlPath)}`);
    data = new mujoco.MjData(model);
    const steps = Math.round(1.0 / model.opt.timestep);
    for (let i = 0; i < steps; i++) mujoco.mj_step(model, data);
    const qpos = Array.from(data.qpos);
    console.log(
      JSON.stringify({
        file: xmlPath,
        version: mujoco.mj_versionString(),
        nbody: model.nbody,
        njnt: model.njnt,
        nu: model.nu,
        nmesh: model.nmesh,
        time: data.time,
        finite: qpos.every(Number.isFinite),
      }),
    );
  } catch (error) {
    failed = true;
    console.log(JSON.stringify({ file: xmlPath, error: String(error?.message ?? error) }));
  } finally {
    data?.delete();
    model?.delete();
  }
}
process.exit(failed ? 1 : 0);
