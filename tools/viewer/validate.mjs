// Runs the Khronos glTF-Validator on one .glb or .gltf file and prints its JSON report.
//
//   node validate.mjs FILE            report on standard output, exit 0 (read the counts in it)
//
// External resources of a .gltf (its .bin) are read from the file's folder. Exit code 2 when the
// file cannot be read or the validator cannot run.
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate.mjs FILE.glb|FILE.gltf');
  process.exit(2);
}
try {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) =>
      readFile(path.join(path.dirname(file), decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
  });
  process.stdout.write(JSON.stringify(report, null, 1) + '\n');
} catch (err) {
  console.error(`validate.mjs: ${file}: ${err && err.message ? err.message : err}`);
  process.exit(2);
}
