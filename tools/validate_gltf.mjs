// Runs the Khronos glTF validator (npm gltf-validator) on each file named on the
// command line and prints one JSON array: per file its error, warning, info and hint
// counts and the messages (code, severity, pointer, text). Exit code 0 when it ran,
// whatever the files contain; 2 on bad usage. Used by robotrial's tests.
import { readFile } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

const SEVERITY = ["error", "warning", "info", "hint"];

async function validate(file) {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 200,
    externalResourceFunction: (uri) =>
      readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then(
        (b) => new Uint8Array(b),
      ),
  });
  const issues = report.issues;
  return {
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    hints: issues.numHints,
    messages: issues.messages.map((m) => ({
      code: m.code,
      severity: SEVERITY[m.severity] ?? String(m.severity),
      pointer: m.pointer ?? "",
      message: m.message,
    })),
  };
}

const files = process.argv.slice(2);
if (files.length === 0) {
  process.stderr.write("usage: node validate_gltf.mjs FILE.glb [FILE.glb ...]\n");
  process.exit(2);
}
const results = [];
for (const file of files) {
  try {
    results.push(await validate(file));
  } catch (err) {
    results.push({ file, errors: 1, warnings: 0, infos: 0, hints: 0,
      messages: [{ code: "UNREADABLE", severity: "error", pointer: "", message: String(err) }] });
  }
}
process.stdout.write(JSON.stringify(results, null, 1) + "\n");
