// Opens the viewer page on one GLB in headless Chromium, moves the camera near and far, saves a
// screenshot, and prints a JSON result:
//   { "loaded": true, "lod": {radius, distances, names}, "near": {distance, level, name, coverage},
//     "far": {...}, "steps": [{distance, level, name} per level], "screenshot": PATH, "triangles": N }
//
//   node check-page.mjs MODEL.glb SCREENSHOT.png [CHROMIUM]
//
// The page and the model are served from 127.0.0.1 on a free port for the run only. Chromium is
// /usr/bin/chromium unless given, with a fresh profile. Exit 0 with the JSON when the page loaded
// the model, 1 when the page reported an error (JSON with "error"), 2 when nothing could run.
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';
import { inChromium, inside, serveFiles } from './browser.mjs';

const [model, shot, exe = '/usr/bin/chromium'] = process.argv.slice(2);
if (!model || !shot) {
  console.error('usage: node check-page.mjs MODEL.glb SCREENSHOT.png [CHROMIUM]');
  process.exit(2);
}
const root = path.dirname(fileURLToPath(import.meta.url));
// The page and its modules from this folder; the model at /model.glb.
const server = await serveFiles((p) => (p === '/model.glb' ? path.resolve(model) : inside(root, p.slice(1))));
const port = server.address().port;
let code = 0;
const launch = { name: 'check-page.mjs', executablePath: exe, viewport: { width: 800, height: 600 } };
code = await inChromium(chromium, launch, async (context) => {
  const page = context.pages()[0] || (await context.newPage());
  const logs = [];
  page.on('console', (m) => logs.push(m.text()));
  page.on('pageerror', (e) => logs.push(String(e)));
  await page.goto(`http://127.0.0.1:${port}/index.html?model=/model.glb`);
  await page.waitForFunction(() => window.octowrap && (window.octowrap.ready || window.octowrap.error), null, { timeout: 90000 });
  const error = await page.evaluate(() => window.octowrap.error);
  if (error) {
    process.stdout.write(JSON.stringify({ loaded: false, error, logs }) + '\n');
    code = 1;
  } else {
    const result = await page.evaluate(() => {
      const s = window.octowrap;
      const r = s.radius;
      const lod = s.lod;
      const finite = lod ? lod.distances.filter((d) => Number.isFinite(d) && d > 0) : [];
      const farDistance = Math.max(r * 40, ...finite.map((d) => d * 1.5));
      const out = { loaded: true, radius: r, lod, triangles: s.triangles, extensionsUsed: s.extensionsUsed };
      out.far = { distance: farDistance, ...s.setDistance(farDistance), coverage: s.coverage() };
      // One camera distance inside each level's range (geometric mean of its switch distances).
      out.steps = lod
        ? lod.distances.map((d, k) => {
            const next = lod.distances[k + 1];
            const distance = k === 0 ? Math.min(r * 2.6, next / 2) : Number.isFinite(next) ? Math.sqrt(d * next) : d * 1.5;
            return { distance, ...s.setDistance(distance) };
          })
        : [];
      out.near = { distance: r * 2.6, ...s.setDistance(r * 2.6), coverage: s.coverage() };
      return out;
    });
    await page.screenshot({ path: shot });
    result.screenshot = shot;
    result.logs = logs;
    process.stdout.write(JSON.stringify(result) + '\n');
  }
  return code;
});
server.close();
process.exit(code);
