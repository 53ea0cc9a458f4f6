// Runs the Khronos glTF-Validator on every content of a 3D Tiles tileset (explicit tiles, or every
// glb file under the tileset's folder when a content URI is an implicit-tiling template) and
// prints one line per file with issues and a total line: "N files: E errors, W warnings". Exit 1
// when any file has an error or a warning, 2 when the tileset cannot be read.
//
//   node validate-tiles.mjs DIR/tileset.json
import { readFile, readdir } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

const tileset = process.argv[2];
if (!tileset) {
  console.error('usage: node validate-tiles.mjs DIR/tileset.json');
  process.exit(2);
}
const dir = path.dirname(tileset);

async function glbsUnder(d) {
  const out = [];
  for (const e of await readdir(d, { withFileTypes: true })) {
    const p = path.join(d, e.name);
    if (e.isDirectory()) out.push(...(await glbsUnder(p)));
    else if (e.name.endsWith('.glb')) out.push(p);
  }
  return out;
}

try {
  const json = JSON.parse(await readFile(tileset, 'utf8'));
  let files = [];
  let templates = false;
  const visit = (t) => {
    if (t.content && t.content.uri && t.content.uri.includes('{')) templates = true;
    else if (t.content && t.content.uri) files.push(path.join(dir, decodeURIComponent(t.content.uri)));
    (t.children || []).forEach(visit);
  };
  visit(json.root);
  if (templates) files = await glbsUnder(dir);
  files.sort();
  let errors = 0;
  let warnings = 0;
  for (const file of files) {
    const report = await validator.validateBytes(new Uint8Array(await readFile(file)), { uri: path.basename(file), maxIssues: 20 });
    const { numErrors, numWarnings } = report.issues;
    errors += numErrors;
    warnings += numWarnings;
    if (numErrors + numWarnings > 0) {
      const codes = report.issues.messages.map((m) => `${m.code} ${m.pointer || ''}`).join('; ');
      console.log(`${path.relative(dir, file)}: ${numErrors} errors, ${numWarnings} warnings: ${codes}`);
    }
  }
  console.log(`${files.length} files: ${errors} errors, ${warnings} warnings`);
  process.exit(errors + warnings > 0 ? 1 : 0);
} catch (err) {
  console.error(`validate-tiles.mjs: ${tileset}: ${err && err.message ? err.message : err}`);
  process.exit(2);
}
