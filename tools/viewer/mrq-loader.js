// HTTP range requests for the MRQ viewer: one call per byte range, with the failures a static
// host can produce turned into messages a user can act on.
//
//   const { bytes, total } = await fetchRange(url, start, end);   // bytes start..end-1
//
// `total` is the file's length from `Content-Range`. Throws an Error whose message says what went
// wrong: not found, no range support, a range past the end (a truncated file), a network failure,
// or a body shorter than its Content-Range.

export class LoadError extends Error {}

export async function fetchRange(url, start, end, stats) {
  const controller = new AbortController();
  let res;
  try {
    res = await fetch(url, {
      headers: { Range: `bytes=${start}-${end - 1}` },
      signal: controller.signal,
      cache: 'no-store',
    });
  } catch (err) {
    throw new LoadError(`cannot fetch ${url}: ${err && err.message ? err.message : err} (network error, or a server on another origin that does not allow it: CORS)`);
  }
  if (stats) stats.requests += 1;
  if (res.status === 404) {
    controller.abort();
    throw new LoadError(`${url} was not found (HTTP 404)`);
  }
  if (res.status === 416) {
    controller.abort();
    const total = totalOf(res.headers.get('content-range'));
    throw new LoadError(`truncated file: ${url} ends at byte ${total ?? '?'}, before byte ${start} (HTTP 416, range not satisfiable)`);
  }
  if (res.status === 200) {
    // The whole file is on its way: stop it, a viewer of large files cannot work this way.
    controller.abort();
    throw new LoadError(`the server does not support HTTP range requests: it answered a request for bytes ${start}-${end - 1} of ${url} with the whole file (HTTP 200). Serve the file from a host that answers Range requests with 206 (nginx, object storage, \`octowrap view\`).`);
  }
  if (res.status !== 206) {
    controller.abort();
    throw new LoadError(`${url}: HTTP ${res.status} ${res.statusText}`);
  }
  const range = /^bytes (\d+)-(\d+)\/(\d+|\*)$/.exec(res.headers.get('content-range') || '');
  if (!range || Number(range[1]) !== start) {
    controller.abort();
    throw new LoadError(`${url}: the server answered bytes ${start}-${end - 1} with Content-Range "${res.headers.get('content-range')}"`);
  }
  const total = range[3] === '*' ? null : Number(range[3]);
  const last = Number(range[2]);
  let bytes;
  try {
    bytes = new Uint8Array(await res.arrayBuffer());
  } catch (err) {
    throw new LoadError(`${url}: the transfer of bytes ${start}-${last} broke off: ${err && err.message ? err.message : err}`);
  }
  if (bytes.length !== last - start + 1) {
    throw new LoadError(`${url}: bytes ${start}-${last} announced, ${bytes.length} received`);
  }
  if (stats) stats.bytes += bytes.length;
  return { bytes, total };
}

function totalOf(header) {
  const m = /\/(\d+)$/.exec(header || '');
  return m ? Number(m[1]) : null;
}
