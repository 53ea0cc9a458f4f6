#!/usr/bin/env bash
# Builds the MRQ viewer's WebAssembly decoder (crates/wasm) into tools/viewer/pkg/:
# octowrap_wasm.js (the wasm-bindgen module the page imports) and octowrap_wasm_bg.wasm.
#
# Needs: the wasm32-unknown-unknown target (rustup target add wasm32-unknown-unknown), clang for
# zstd's C code (apt-get install clang), wasm-bindgen-cli at the version of the wasm-bindgen crate
# in Cargo.lock (cargo install wasm-bindgen-cli --version X), and optionally wasm-opt (Debian's
# binaryen). Build octowrap after this script: it embeds pkg/ for `octowrap view`.
set -euo pipefail
cd "$(dirname "$0")/../.."
export CC_wasm32_unknown_unknown="${CC_wasm32_unknown_unknown:-clang}"
export AR_wasm32_unknown_unknown="${AR_wasm32_unknown_unknown:-$(command -v llvm-ar || ls /usr/bin/llvm-ar-* 2>/dev/null | sort -V | tail -1)}"
# Small and fast: one codegen unit, link-time optimization, no unwinding, no debug lines.
export CARGO_PROFILE_RELEASE_LTO=true CARGO_PROFILE_RELEASE_CODEGEN_UNITS=1 CARGO_PROFILE_RELEASE_PANIC=abort \
  CARGO_PROFILE_RELEASE_DEBUG=false
cargo build --release --target wasm32-unknown-unknown -p octowrap-wasm
want="$(grep -A1 '^name = "wasm-bindgen"$' Cargo.lock | sed -n 's/^version = "\(.*\)"$/\1/p')"
have="$(wasm-bindgen --version 2>/dev/null | awk '{print $2}')" || true
if [ "$have" != "$want" ]; then
  echo "build-wasm.sh: wasm-bindgen $want is needed (found '${have:-none}'): cargo install wasm-bindgen-cli --version $want" >&2
  exit 2
fi
out=tools/viewer/pkg
mkdir -p "$out"
wasm-bindgen --target web --no-typescript --out-dir "$out" target/wasm32-unknown-unknown/release/octowrap_wasm.wasm
if command -v wasm-opt >/dev/null 2>&1; then
  wasm-opt -O3 --enable-bulk-memory --enable-nontrapping-float-to-int --enable-sign-ext --enable-mutable-globals \
    "$out/octowrap_wasm_bg.wasm" -o "$out/octowrap_wasm_bg.wasm.opt"
  mv "$out/octowrap_wasm_bg.wasm.opt" "$out/octowrap_wasm_bg.wasm"
fi
echo "$out/octowrap_wasm_bg.wasm: $(wc -c < "$out/octowrap_wasm_bg.wasm") bytes, $(gzip -9 -c "$out/octowrap_wasm_bg.wasm" | wc -c) gzipped"
