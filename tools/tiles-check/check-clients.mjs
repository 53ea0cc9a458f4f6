// Opens a 3D Tiles tileset in two real clients in headless Chromium, 3DTilesRendererJS (three.js,
// three.html) and CesiumJS (cesium.html), moves each camera to the far and the near view of
// views.js, saves a screenshot of each, and prints one JSON object:
//   { "<client>": { "placement": {...} (CesiumJS), "views": { "far": {frames, eye, tiles: [...]},
//                   "near": {...} }, "cracks": {modelPixels, missingPixels, fraction, holePixels, holeFraction} (three),
//                   "screenshots": [PATH...], "errors": [console errors and failed requests],
//                   "warnings": [...], "seconds": N } }
// Each drawn tile is {uri, geometricError, depth, leaf, distance} as the client reports it,
// nearest first.
//
//   node check-clients.mjs DIR/tileset.json OUTDIR [--clients three,cesium] [--views far,near,given]
//                          [--no-cracks] [--view ex,ey,ez,tx,ty,tz] [--error-target PIXELS] [--chromium PATH]
//
// --view adds the view `given` (root frame: eye, then target), where the crack measure is then
// taken; --views keeps only the views named; --no-cracks leaves the crack measure out; --error-target is both clients' screen-space error
// in pixels (default 16, as both clients default to).
//
// This folder and the tileset's folder are served from 127.0.0.1 on a free port for the run only
// (nothing else is fetched: no Cesium ion, no imagery, no terrain). Chromium is /usr/bin/chromium
// unless given, with a fresh profile. Exit 0 with the JSON when every page loaded and ran, 1 when a
// page reported an error (the JSON says which), 2 when nothing could run.
import { mkdir, writeFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';
import { inChromium, inside, serveFiles } from '../viewer/browser.mjs';

const args = process.argv.slice(2);
const positional = [];
const opts = { clients: 'three,cesium', cracks: true, views: null, view: null, errorTarget: '16', chromium: '/usr/bin/chromium' };
for (let i = 0; i < args.length; i++) {
  const a = args[i];
  if (a === '--clients') opts.clients = args[++i];
  else if (a === '--view') opts.view = args[++i];
  else if (a === '--views') opts.views = args[++i].split(',');
  else if (a === '--no-cracks') opts.cracks = false;
  else if (a === '--error-target') opts.errorTarget = args[++i];
  else if (a === '--chromium') opts.chromium = args[++i];
  else positional.push(a);
}
const [tileset, outDir] = positional;
if (!tileset || !outDir) {
  console.error('usage: node check-clients.mjs DIR/tileset.json OUTDIR [--clients three,cesium] [--views far,near,given] [--no-cracks] [--view ex,ey,ez,tx,ty,tz] [--error-target PIXELS] [--chromium PATH]');
  process.exit(2);
}
const root = path.dirname(fileURLToPath(import.meta.url));
const dataDir = path.resolve(path.dirname(tileset));
// The pages and their modules from this folder; the tileset's folder under /data/.
const server = await serveFiles((p) => (p.startsWith('/data/') ? inside(dataDir, p.slice('/data/'.length)) : inside(root, p.slice(1))));
const port = server.address().port;
await mkdir(outDir, { recursive: true });
const out = {};
let code = 0;
const launch = { name: 'check-clients.mjs', executablePath: opts.chromium, viewport: { width: 600, height: 600 } };
code = await inChromium(chromium, launch, async (context) => {
  for (const client of opts.clients.split(',')) {
    const started = Date.now();
    const page = await context.newPage();
    const errors = [];
    const warnings = [];
    page.on('console', (m) => {
      if (m.type() === 'error') errors.push(m.text());
      else if (m.type() === 'warning') warnings.push(m.text());
    });
    page.on('pageerror', (e) => errors.push(String(e)));
    page.on('requestfailed', (r) => errors.push(`request failed: ${r.url()}: ${r.failure() && r.failure().errorText}`));
    page.on('response', (r) => { if (r.status() >= 400) errors.push(`HTTP ${r.status()}: ${r.url()}`); });
    const q = new URLSearchParams({ tileset: '/data/' + path.basename(tileset), errorTarget: opts.errorTarget });
    if (opts.view) q.set('view', opts.view);
    const result = { screenshots: [], errors, warnings };
    out[client] = result;
    try {
      await page.goto(`http://127.0.0.1:${port}/${client}.html?${q}`);
      await page.waitForFunction(() => window.octowrap && (window.octowrap.ready || window.octowrap.error), null, { timeout: 60000 });
      const error = await page.evaluate(() => window.octowrap.error);
      if (error) throw new Error(error);
      result.placement = await page.evaluate(() => window.octowrap.placement || null);
      const names = (await page.evaluate(() => window.octowrap.views)).filter((n) => !opts.views || opts.views.includes(n));
      result.views = {};
      for (const name of names) {
        result.views[name] = await page.evaluate((n) => window.octowrap.view(n), name);
        const shot = path.join(outDir, `${client}-${name}.png`);
        await page.screenshot({ path: shot });
        result.screenshots.push(shot);
      }
      if (client === 'three' && opts.cracks) {
        const name = names.includes('given') ? 'given' : 'near';
        result.cracks = await page.evaluate((n) => window.octowrap.cracks(n), name);
        const shot = path.join(outDir, `${client}-cracks.png`);
        await writeFile(shot, Buffer.from(result.cracks.picture.split(',')[1], 'base64'));
        delete result.cracks.picture;
        result.screenshots.push(shot);
      }
    } catch (err) {
      result.error = String(err && err.message ? err.message : err);
      code = 1;
    }
    if (errors.length > 0) code = 1;
    result.seconds = (Date.now() - started) / 1000;
    await page.close();
  }
  process.stdout.write(JSON.stringify(out) + '\n');
  return code;
});
server.close();
process.exit(code);
