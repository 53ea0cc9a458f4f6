// What the headless-Chromium checks share (check-page.mjs, check-mrq.mjs and
// tools/tiles-check/check-clients.mjs): a static file server on 127.0.0.1, Chromium's flags and
// a run of headless Chromium in a fresh profile.
import http from 'node:http';
import { mkdtemp, readFile, rm } from 'node:fs/promises';
import os from 'node:os';
import path from 'node:path';

/// Content types by file extension; anything else is application/octet-stream.
const TYPES = {
  '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript', '.json': 'application/json',
  '.glb': 'model/gltf-binary', '.wasm': 'application/wasm', '.css': 'text/css', '.png': 'image/png',
  '.subtree': 'application/octet-stream',
};

/// Chromium's flags for the checks: no sandbox (containers), software WebGL (SwiftShader), no
/// network services of its own.
export const CHROMIUM_ARGS = ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync', '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader'];

/// The file under `dir` that the URL path `rel` (normalized, leading '/' removed) names, or null
/// when it would leave `dir`.
export function inside(dir, rel) {
  const file = path.join(dir, rel);
  return file.startsWith(dir + path.sep) ? file : null;
}

/// Serves GET requests on 127.0.0.1 (a free port): `resolve(pathname)` gives the file for a URL
/// path (decoded and normalized, starting with '/') or null; 404 for null and for unreadable
/// files. Resolves to the listening server (`server.address().port`).
export async function serveFiles(resolve) {
  const server = http.createServer(async (req, res) => {
    try {
      const pathname = path.normalize(decodeURIComponent(new URL(req.url, 'http://localhost').pathname));
      const file = resolve(pathname);
      if (!file) throw new Error('not served');
      const body = await readFile(file);
      res.writeHead(200, { 'content-type': TYPES[path.extname(file)] || 'application/octet-stream' });
      res.end(body);
    } catch {
      res.writeHead(404);
      res.end();
    }
  });
  await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
  return server;
}

/// Runs `body(context)` in headless Chromium (playwright-core's `chromium`, from the caller's own
/// node_modules) with a fresh profile, removed afterwards; `launch` adds to the launch options
/// (`executablePath`, `viewport`), `name` names the script in an error. Resolves to the body's
/// exit code (0 when it returns none), or 2 when it throws (the error printed).
export async function inChromium(chromium, { name, ...launch }, body) {
  const profile = await mkdtemp(path.join(os.tmpdir(), 'octowrap-chromium-'));
  let context;
  try {
    context = await chromium.launchPersistentContext(profile, { headless: true, args: CHROMIUM_ARGS, ...launch });
    return (await body(context)) ?? 0;
  } catch (err) {
    console.error(`${name}: ${err && err.message ? err.message : err}`);
    return 2;
  } finally {
    if (context) await context.close();
    await rm(profile, { recursive: true, force: true });
  }
}
