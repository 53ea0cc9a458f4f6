//! Embeds the MRQ web viewer (`tools/viewer`) into the binary for `octowrap view`: the page, its
//! scripts, the WebAssembly decoder (`tools/viewer/pkg`, built by `tools/viewer/build-wasm.sh`)
//! and three.js (`tools/viewer/node_modules`, installed by `npm ci`). Files that are not there
//! are listed as missing; `octowrap view` names them and how to build them.

use std::fmt::Write as _;
use std::path::Path;

/// Served path, source path under `tools/viewer`, content type.
const ASSETS: &[(&str, &str, &str)] = &[
    ("/mrq.html", "mrq.html", "text/html; charset=utf-8"),
    ("/mrq.js", "mrq.js", "text/javascript"),
    ("/mrq-worker.js", "mrq-worker.js", "text/javascript"),
    ("/mrq-loader.js", "mrq-loader.js", "text/javascript"),
    ("/pkg/octowrap_wasm.js", "pkg/octowrap_wasm.js", "text/javascript"),
    ("/pkg/octowrap_wasm_bg.wasm", "pkg/octowrap_wasm_bg.wasm", "application/wasm"),
    ("/node_modules/three/build/three.module.js", "node_modules/three/build/three.module.js", "text/javascript"),
    ("/node_modules/three/build/three.core.js", "node_modules/three/build/three.core.js", "text/javascript"),
    (
        "/node_modules/three/examples/jsm/controls/OrbitControls.js",
        "node_modules/three/examples/jsm/controls/OrbitControls.js",
        "text/javascript",
    ),
];

fn main() {
    let manifest = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let viewer = Path::new(&manifest).join("../../tools/viewer");
    // The folder as a whole: cargo looks at every file in it, so the build sees pkg/ and
    // node_modules/ appear or change.
    println!("cargo::rerun-if-changed={}", viewer.display());
    let mut code = String::from("/// The viewer's files, embedded at build time.\nstatic ASSETS: &[Asset] = &[\n");
    let mut missing = String::from("/// Viewer files that were missing at build time.\nstatic MISSING: &[&str] = &[\n");
    for (path, file, mime) in ASSETS {
        let source = viewer.join(file);
        if source.is_file() {
            let source = source.canonicalize().expect("an existing file has a canonical path");
            // A Rust string literal of the path (Debug quotes and escapes it).
            let literal = format!("{:?}", source.to_string_lossy());
            writeln!(code, "    Asset {{ path: {path:?}, mime: {mime:?}, bytes: include_bytes!({literal}) }},")
                .unwrap();
        } else {
            writeln!(missing, "    \"tools/viewer/{file}\",").unwrap();
        }
    }
    code.push_str("];\n");
    missing.push_str("];\n");
    let out = Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("viewer_assets.rs");
    std::fs::write(out, code + &missing).expect("OUT_DIR is writable");
}
