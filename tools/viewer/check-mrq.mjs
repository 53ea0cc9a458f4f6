// Opens the MRQ viewer (mrq.html, served by `octowrap view`) in headless Chromium and prints one
// JSON result: the first frame (range requests and bytes before it), every level shown, console
// errors, the crack check, the decoding speed against draco3d, and the messages for bad input.
//
//   node check-mrq.mjs --url URL --mrq FILE.mrq --out DIR
//                      [--truncated URL] [--corrupted URL] [--chromium PATH]
//   node check-mrq.mjs --url URL --mrq FILE.mrq --out DIR --view-camera CAMERA.json
//
// The level checks ask for `mode=levels`. With --view-camera, the page's default mode instead
// (view mode, for a chunked file): the first frame, then
// the close-up of the camera file (the schema of `octowrap decimate --view`), what its cut drew
// and fetched, and the crack check from there; --truncated and --corrupted pages then show their
// messages in view mode.
//
// --url is the page URL `octowrap view FILE.mrq --no-open` printed; --mrq the same file (for the
// Draco copy of its finest level); --truncated and --corrupted are pages of other `view`
// servers showing damaged copies. A server without range support and a missing file are tested
// here: the first with a small server of this script's own, the second with the page's server.
// Screenshots go to DIR. Exit 0 with the JSON, 1 when the main page failed, 2 when nothing ran.
import http from 'node:http';
import { mkdtemp, readFile, rm } from 'node:fs/promises';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';
import draco3d from 'draco3d';
import { CHROMIUM_ARGS } from './browser.mjs';
import { decodeFinest, loadDecoder } from './mrq-node.mjs';

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
if (!args.url || !args.mrq || !args.out) {
  console.error('usage: node check-mrq.mjs --url URL --mrq FILE.mrq --out DIR [--truncated URL] [--corrupted URL]');
  process.exit(2);
}
const root = path.dirname(fileURLToPath(import.meta.url));
const exe = args.chromium || '/usr/bin/chromium';

// The finest level decoded by the same WebAssembly module in Node, then Draco-coded (draco3d's
// encoder: 14-bit positions, the default speed), for the decoding comparison in the page.
async function dracoOfFinest(file) {
  const { positions, indices } = decodeFinest(await loadDecoder(), new Uint8Array(await readFile(file)));
  const enc = await draco3d.createEncoderModule({});
  const mesh = new enc.Mesh();
  const builder = new enc.MeshBuilder();
  builder.AddFacesToMesh(mesh, indices.length / 3, indices);
  builder.AddFloatAttributeToMesh(mesh, enc.POSITION, positions.length / 3, 3, positions);
  const encoder = new enc.Encoder();
  encoder.SetAttributeQuantization(enc.POSITION, 14);
  const out = new enc.DracoInt8Array();
  const n = encoder.EncodeMeshToDracoBuffer(mesh, out);
  if (n <= 0) throw new Error('draco3d could not encode the finest level');
  const drc = new Uint8Array(n);
  for (let i = 0; i < n; i++) drc[i] = out.GetValue(i);
  enc.destroy(out);
  enc.destroy(encoder);
  enc.destroy(builder);
  enc.destroy(mesh);
  return { drc, vertices: positions.length / 3, triangles: indices.length / 3 };
}

// A static server that ignores Range: every GET gets the whole file with 200.
function noRangeServer(file) {
  const server = http.createServer(async (req, res) => {
    const body = await readFile(file);
    res.writeHead(200, {
      'content-type': 'application/octet-stream', 'access-control-allow-origin': '*',
      'access-control-allow-headers': 'range', 'content-length': body.length,
    });
    res.end(req.method === 'OPTIONS' ? undefined : body);
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(server)));
}

const profile = await mkdtemp(path.join(os.tmpdir(), 'octowrap-chromium-'));
let context;
let code = 0;
let plain;
const result = {};
try {
  context = await chromium.launchPersistentContext(profile, {
    executablePath: exe,
    headless: true,
    viewport: { width: 800, height: 600 },
    args: CHROMIUM_ARGS,
  });
  // Opens `url`, waits until the stream ends (done or error), returns the page's state.
  const open = async (url, name) => {
    const page = await context.newPage();
    const errors = [];
    const requests = [];
    page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
    page.on('pageerror', (e) => errors.push(String(e)));
    // Chromium's console line for a failed load names no URL: the responses do.
    page.on('response', (r) => { if (r.status() >= 400) errors.push(`${r.status()} ${r.url()}`); });
    context.on('request', (r) => { if (r.headers().range) requests.push(r.headers().range); });
    await page.goto(url);
    const t0 = Date.now();
    await page.waitForFunction(() => window.octowrap && (window.octowrap.done || window.octowrap.error), null, { timeout: 60000 });
    const state = await page.evaluate(() => {
      const s = window.octowrap;
      return { done: s.done, error: s.error, firstFrame: s.firstFrame, shown: s.shown, stats: s.stats,
        fileSize: s.fileSize, levels: s.info ? s.info.levels.length : null, panel: document.getElementById('panel').textContent,
        message: document.getElementById('error').textContent };
    });
    state.waitMs = Date.now() - t0;
    state.consoleErrors = errors;
    state.rangeHeaders = requests.slice();
    state.screenshot = path.join(args.out, `mrq-${name}.png`);
    await page.screenshot({ path: state.screenshot });
    return { page, state };
  };

  if (args['view-camera']) {
    // View mode: the first frame, then a close-up for the camera file, the cut it drew, the bytes
    // fetched for it, the crack check from that camera.
    const cam = JSON.parse(await readFile(args['view-camera'], 'utf8'));
    // The page's default mode: a chunked file is viewed view-dependently.
    const url = `${args.url}&px=${cam.pixel_error ?? 1}`;
    const { page: p, state: s } = await open(url, 'view-first');
    result.view = s;
    if (!s.error) {
      result.view.closeUp = await p.evaluate(async (c) => {
        const cut = await window.octowrap.viewTo(c.position, c.target, c.up ?? [0, 0, 1], c.fov_y_degrees);
        return { cut, stats: window.octowrap.stats, fileSize: window.octowrap.fileSize };
      }, cam);
      await p.screenshot({ path: path.join(args.out, 'mrq-view-close.png') });
      result.view.crack = await p.evaluate(() => window.octowrap.crackCheck());
      result.view.panel = await p.evaluate(() => document.getElementById('panel').textContent);
      result.view.mode = await p.evaluate(() => window.octowrap.info && window.octowrap.info.mode);
      await p.screenshot({ path: path.join(args.out, 'mrq-view-close-after-check.png') });
    } else {
      code = 1;
    }
    await p.close();
    // The close-up straight away, on a fresh page: what a client that opens on it fetches.
    const { page: q, state: d } = await open(`${url}&cam=${encodeURIComponent(JSON.stringify(cam))}`, 'view-direct');
    result.direct = { error: d.error, firstFrame: d.firstFrame, consoleErrors: d.consoleErrors };
    if (!d.error) {
      result.direct.cut = await q.evaluate(() => window.octowrap.lastCut);
      result.direct.crack = await q.evaluate(() => window.octowrap.crackCheck());
    }
    await q.close();
    // Damaged copies in view mode: a message in the page, not a hang.
    result.viewBad = {};
    for (const [name, damaged] of [['truncated', args.truncated], ['corrupted', args.corrupted]]) {
      if (!damaged) continue;
      const { page: b, state: s } = await open(damaged, `view-${name}`);
      result.viewBad[name] = { error: s.error, mode: await b.evaluate(() => window.octowrap.info && window.octowrap.info.mode),
        shown: s.shown.map((l) => l.level), waitMs: s.waitMs, consoleErrors: s.consoleErrors };
      await b.close();
    }
  } else {
    await levelChecks(open);
  }
} catch (err) {
  console.error(`check-mrq.mjs: ${err && err.stack ? err.stack : err}`);
  code = 2;
} finally {
  if (context) await context.close();
  if (plain) plain.close();
  await rm(profile, { recursive: true, force: true });
}
process.stdout.write(JSON.stringify(result) + '\n');
process.exit(code);

// Level mode: the stream, the crack check, the decoding speed against draco3d, and bad input.
async function levelChecks(open) {
  const { page, state } = await open(`${args.url}&mode=levels`, 'streamed');
  result.main = state;
  if (state.error) {
    code = 1;
  } else {
    result.crack = await page.evaluate(() => window.octowrap.crackCheck());
    await page.evaluate(() => window.octowrap.setView([0.1, 0.6, 0.4], 1.2));
    await page.screenshot({ path: path.join(args.out, 'mrq-close.png') });
    const { drc, vertices } = await dracoOfFinest(args.mrq);
    await page.addScriptTag({ path: path.join(root, 'node_modules/draco3d/draco_decoder_nodejs.js') });
    const dracoWasm = await readFile(path.join(root, 'node_modules/draco3d/draco_decoder.wasm'));
    result.bench = await page.evaluate(async ([d, w]) => window.octowrap.bench(new Uint8Array(d), new Uint8Array(w).buffer),
      [Array.from(drc), Array.from(dracoWasm)]);
    result.bench.drcBytes = drc.length;
    result.bench.nodeVertices = vertices;
  }
  await page.close();

  // Bad input: each must end with a message in the page, not hang.
  result.bad = {};
  const bad = async (name, url) => {
    const { page: p, state: s } = await open(url, name);
    result.bad[name] = { error: s.error, shown: s.shown.map((l) => l.level), waitMs: s.waitMs, consoleErrors: s.consoleErrors };
    await p.close();
  };
  const base = new URL(args.url);
  await bad('notfound', new URL('/mrq.html?src=/data/missing.mrq', base).href);
  plain = await noRangeServer(args.mrq);
  await bad('norange', new URL(`/mrq.html?src=${encodeURIComponent(`http://127.0.0.1:${plain.address().port}/file.mrq`)}`, base).href);
  if (args.truncated) await bad('truncated', `${args.truncated}&mode=levels`);
  if (args.corrupted) await bad('corrupted', `${args.corrupted}&mode=levels`);
  await bad('nosrc', new URL('/mrq.html', base).href);
}
