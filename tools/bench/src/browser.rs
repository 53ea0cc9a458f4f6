//! The browser area: the MRQ viewer page (`tools/viewer/mrq.html`, served by
//! `octowrap view`) in headless Chromium on a reconstructed dragon, through
//! `tools/viewer/check-mrq.mjs`: the first frame (range requests, bytes, time), the whole
//! stream, and the WebAssembly decoder against the `draco3d` decoder on the same finest level in
//! the same page. Beside it, what WebAssembly itself costs: the same module in Node
//! (`tools/viewer/bench-decode.mjs`) against the same Rust code natively on one thread
//! (`octowrap_wasm::stream::Stream`, the code the module is built from), and the module's size.
//!
//! Needs the binary (`cargo build --release -p octowrap-cli`, after `tools/viewer/build-wasm.sh`
//! so that it embeds the module), `npm ci` in `tools/viewer`, Node and `/usr/bin/chromium`.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

use octowrap_wasm::stream::Stream;
use serde_json::Value;

use crate::util::{best_of, headline, octowrap_binary, shared_data};

/// Runs of each decoder; the median (in the page and in Node) or the best (native) is reported.
const RUNS: usize = 15;

/// `octowrap view FILE --no-open --port 0`, stopped when dropped.
struct Viewer(Child);

impl Drop for Viewer {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts the viewer's server on `file`; its page URL.
fn serve(bin: &Path, file: &Path) -> Result<(Viewer, String), String> {
    let mut child = Command::new(bin)
        .arg("view")
        .arg(file)
        .args(["--no-open", "--port", "0"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", bin.display()))?;
    let mut line = String::new();
    let stdout = child.stdout.take().ok_or("no standard output")?;
    let viewer = Viewer(child);
    BufReader::new(stdout).read_line(&mut line).map_err(|e| format!("octowrap view: {e}"))?;
    let url = line.trim().to_owned();
    if !url.starts_with("http://") {
        return Err(format!("octowrap view printed {url:?}, not its URL"));
    }
    Ok((viewer, url))
}

/// Runs `node script args`; its one line of JSON.
fn node_json(script: &Path, args: &[&str]) -> Result<Value, String> {
    let o = Command::new("node").arg(script).args(args).output().map_err(|e| format!("node: {e}"))?;
    let text = String::from_utf8_lossy(&o.stdout);
    let v: Value = serde_json::from_str(text.trim())
        .map_err(|_| format!("{} printed no JSON: {}", script.display(), String::from_utf8_lossy(&o.stderr).trim()))?;
    if o.status.success() { Ok(v) } else { Err(format!("{} failed: {v}", script.display())) }
}

/// What the area needs, or why it cannot run.
fn missing(viewer: &Path) -> Option<String> {
    let needs = [
        (viewer.join("node_modules/playwright-core"), "npm ci in tools/viewer"),
        (viewer.join("node_modules/draco3d"), "npm ci in tools/viewer"),
        (viewer.join("pkg/octowrap_wasm_bg.wasm"), "tools/viewer/build-wasm.sh"),
        (Path::new("/usr/bin/chromium").to_path_buf(), "apt-get install chromium"),
    ];
    needs.iter().find(|(p, _)| !p.exists()).map(|(p, how)| format!("{} is missing ({how})", p.display()))
}

/// Runs the area.
pub fn report() {
    outln!("## Browser: the MRQ viewer page and its WebAssembly decoder");
    outln!();
    let viewer = octowrap_testdata::workspace_root().join("tools/viewer");
    let Some(bin) = octowrap_binary() else {
        outln!(
            "SKIPPED: target/release/octowrap is missing (cargo build --release -p octowrap-cli, or set OCTOWRAP_BIN)"
        );
        return;
    };
    if let Some(why) = missing(&viewer) {
        outln!("SKIPPED: {why}");
        return;
    }
    let Some(points) = shared_data().map(|d| d.join("stanford-dragon/dragon_vrip.ply.gz")).filter(|p| p.is_file())
    else {
        outln!("SKIPPED: stanford-dragon/dragon_vrip.ply.gz is not in the data folder (set OCTOWRAP_DATA)");
        return;
    };
    if let Err(why) = measure(&bin, &viewer, &points) {
        outln!("SKIPPED: {why}");
    }
}

fn measure(bin: &Path, viewer: &Path, points: &Path) -> Result<(), String> {
    let dir = tempfile::tempdir().map_err(|e| format!("a temporary folder: {e}"))?;
    let mrq = dir.path().join("dragon.mrq");
    let o = Command::new(bin)
        .arg("reconstruct")
        .arg(points)
        .arg("-o")
        .arg(&mrq)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", bin.display()))?;
    if !o.status.success() {
        return Err(format!("reconstruct failed: {}", String::from_utf8_lossy(&o.stderr).trim()));
    }
    let bytes = std::fs::read(&mrq).map_err(|e| format!("{}: {e}", mrq.display()))?;
    let (_server, url) = serve(bin, &mrq)?;
    let out = dir.path().to_str().ok_or("a temporary folder with a UTF-8 name")?;
    let mrq_arg = mrq.to_str().ok_or("a temporary file with a UTF-8 name")?;
    let page = node_json(&viewer.join("check-mrq.mjs"), &["--url", &url, "--mrq", mrq_arg, "--out", out])?;
    let node = node_json(&viewer.join("bench-decode.mjs"), &[mrq_arg, &RUNS.to_string()])?;
    let native = native_decode(&bytes)?;
    let module = std::fs::read(viewer.join("pkg/octowrap_wasm_bg.wasm")).map_err(|e| format!("the module: {e}"))?;
    let gz = gzipped_len(&module);
    print(&page, &node, native, (module.len(), gz), bytes.len());
    Ok(())
}

/// The native decode of the finest level on one thread, as the module does it: best seconds and
/// vertices.
fn native_decode(bytes: &[u8]) -> Result<(f64, u32), String> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().map_err(|e| e.to_string())?;
    let once = || {
        let mut s = Stream::new(u64::MAX);
        s.set_file_len(bytes.len() as u64).map_err(|e| e.to_string())?;
        s.push(0, bytes).map_err(|e| e.to_string())?;
        let k = s.info().map_or(0, |i| i.levels.len() as u32).saturating_sub(1);
        let m = s.decode(k).map_err(|e| e.to_string())?;
        Ok::<u32, String>((m.positions.len() / 3) as u32)
    };
    pool.install(|| {
        once()?;
        let (secs, v) = best_of(RUNS, once);
        Ok((secs, v?))
    })
}

fn gzipped_len(data: &[u8]) -> usize {
    use std::io::Write as _;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    let _ = e.write_all(data);
    e.finish().map_or(0, |v| v.len())
}

/// The table and the headlines.
fn print(page: &Value, node: &Value, (native_s, native_v): (f64, u32), (module, gz): (usize, usize), file: usize) {
    let num = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let main = &page["main"];
    let first = &main["firstFrame"];
    let bench = &page["bench"];
    let (wasm_mvps, draco_mvps) = (num(&bench["wasmMVps"]), num(&bench["dracoMVps"]));
    let speedup = num(&bench["speedup"]);
    let node_ms = num(&node["medianMs"]);
    let node_mvps = num(&node["vertices"]) / node_ms / 1e3;
    let native_mvps = f64::from(native_v) / native_s / 1e6;
    let crack = num(&page["crack"]["fraction"]) * 100.0;
    outln!(
        "dragon reconstructed by `octowrap reconstruct` ({file} bytes, {} levels), served by `octowrap view`",
        main["levels"]
    );
    outln!();
    outln!("| case | figure | target |");
    outln!("|---|---|---|");
    outln!(
        "| first frame: level {}, range requests, bytes, time after load | {}, {} B, {:.0} ms | ≤ 2 requests, ≤ 64 KB |",
        first["level"],
        first["requests"],
        first["bytes"],
        num(&first["ms"])
    );
    outln!(
        "| whole file: range requests, bytes fetched | {}, {} B of {file} | each byte once |",
        main["stats"]["requests"],
        main["stats"]["bytes"]
    );
    outln!("| cracks: finest-level pixels the streamed view misses | {crack:.3} % | ≤ 0.05 % |");
    outln!(
        "| finest level ({} vertices) in Chromium, median of 9: WebAssembly MRQ / draco3d | {wasm_mvps:.2} / {draco_mvps:.2} M vertices/s = {speedup:.2}x | ≥ 2x |",
        bench["vertices"]
    );
    outln!(
        "| the same in Node, median of {RUNS}: WebAssembly / native Rust on 1 thread, best of {RUNS} | {node_mvps:.2} / {native_mvps:.2} M vertices/s = {:.2}x | – |",
        node_mvps / native_mvps
    );
    outln!("| WebAssembly module: bytes, gzipped | {module} B, {gz} B | < 300 KB gzipped |");
    outln!("| console errors on the page | {} | none |", main["consoleErrors"]);
    outln!();
    headline(
        "finest dragon level in Chromium: WebAssembly MRQ / draco3d decoding",
        format!("{speedup:.2}x ({wasm_mvps:.2} / {draco_mvps:.2} M vertices/s)"),
        "≥ 2x",
        Some(speedup >= 2.0),
    );
    headline(
        "WebAssembly in Node / native Rust on 1 thread, same decoder",
        format!("{:.2}x ({node_mvps:.2} / {native_mvps:.2} M vertices/s)", node_mvps / native_mvps),
        "–",
        None,
    );
    let first_ok =
        first["requests"].as_u64().is_some_and(|r| r <= 2) && first["bytes"].as_u64().is_some_and(|b| b <= 64 << 10);
    headline(
        "first frame: range requests, bytes",
        format!("{}, {} B (level {})", first["requests"], first["bytes"], first["level"]),
        "≤ 2, ≤ 64 KB",
        Some(first_ok),
    );
    headline("WebAssembly module, gzipped", format!("{gz} B"), "< 300 KB", Some(gz < 300_000));
}
