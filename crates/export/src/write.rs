//! Containers: GLB (glTF 2.0 §4.4, binary glTF) and `.gltf` + `.bin`, written with
//! [`octowrap_fsutil::write_file`].

use std::fmt::Write as _;
use std::path::Path;

use crate::document::Built;
use crate::{Error, ExportOptions, Summary, to_glb, to_gltf};
use octowrap_mesh::Hierarchy;

/// The two glTF container forms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// One binary `.glb` file: JSON chunk plus binary chunk.
    Glb,
    /// A `.gltf` JSON file and a `.bin` file beside it with the same stem.
    Gltf,
}

impl Container {
    /// The container an output path's extension names (`.glb` or `.gltf`, any case).
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?;
        if ext.eq_ignore_ascii_case("glb") {
            Some(Self::Glb)
        } else if ext.eq_ignore_ascii_case("gltf") {
            Some(Self::Gltf)
        } else {
            None
        }
    }
}

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: &[u8; 4] = b"JSON";
const CHUNK_BIN: &[u8; 4] = b"BIN\0";

fn json_bytes(built: &Built, pretty: bool) -> Vec<u8> {
    let r = if pretty { serde_json::to_vec_pretty(&built.root) } else { serde_json::to_vec(&built.root) };
    r.expect("the glTF model holds only strings, numbers and maps with string keys")
}

/// Packs a built document as GLB: 12-byte header, JSON chunk padded with spaces, binary chunk
/// padded with zeros, every chunk 4-byte aligned.
pub(crate) fn glb(built: Built) -> Result<(Vec<u8>, Summary), Error> {
    let mut json = json_bytes(&built, false);
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut bin = built.bin;
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() as u64 + if bin.is_empty() { 0 } else { 8 + bin.len() as u64 };
    let Ok(total32) = u32::try_from(total) else {
        return Err(Error::limit(format!("the GLB would be {total} bytes; the format's limit is 4 GiB")));
    };
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(GLB_MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total32.to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(CHUNK_JSON);
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(CHUNK_BIN);
        out.extend_from_slice(&bin);
    }
    let mut summary = built.summary;
    summary.bytes = total;
    Ok((out, summary))
}

/// Returns the pretty-printed JSON and the binary buffer.
pub(crate) fn gltf(built: Built) -> (Vec<u8>, Vec<u8>, Summary) {
    let json = json_bytes(&built, true);
    let mut summary = built.summary;
    summary.bytes = (json.len() + built.bin.len()) as u64;
    (json, built.bin, summary)
}

/// An error of building the document, for [`write_path`]: what is wrong with the input
/// ([`Error::Invalid`]) names no file, so that the caller names the input (the output is not
/// what is broken); what does not fit the output names it.
fn output_error(e: Error, output: &str) -> Error {
    match e {
        Error::Invalid { .. } => e,
        other => other.in_file(output),
    }
}

/// Exports `h` to `path`: GLB for `.glb`, or for `.gltf` the JSON plus `STEM.bin` beside it. Each
/// file is written with [`octowrap_fsutil::write_file`] (to a temporary file in the same folder,
/// renamed into place when complete, so a failed export leaves nothing half-written; a replaced
/// file keeps its mode and a symbolic link stays a link). With [`ExportOptions::no_clobber`], an
/// existing file is refused before anything is written. Errors name the output file, except
/// those about the input ([`Error::Invalid`]: no faces, broken indices, ...), which name none.
///
/// ```no_run
/// use octowrap_export::{ExportOptions, Levels, write_path};
/// # let hierarchy = octowrap_mesh::Hierarchy::default();
/// let mut options = ExportOptions::default();
/// options.levels = Levels::All;
/// options.quantize = true;
/// let summary = write_path("dragon.glb".as_ref(), &hierarchy, &options)?;
/// println!("{} levels, {} bytes", summary.levels.len(), summary.bytes);
/// # Ok::<(), octowrap_export::Error>(())
/// ```
pub fn write_path(path: &Path, h: &Hierarchy, opts: &ExportOptions) -> Result<Summary, Error> {
    let name = path.display().to_string();
    let file_opts = octowrap_fsutil::WriteOptions::no_clobber(opts.no_clobber);
    match Container::from_path(path) {
        Some(Container::Glb) => {
            check(path, &file_opts)?;
            let (bytes, summary) = to_glb(h, opts).map_err(|e| output_error(e, &name))?;
            write_file(path, &file_opts, &bytes)?;
            Ok(summary)
        }
        Some(Container::Gltf) => {
            let bin_path = path.with_extension("bin");
            let Some(bin_name) = bin_path.file_name().and_then(|n| n.to_str()) else {
                return Err(Error::Unsupported {
                    file: name,
                    message: "the .bin file name beside it must be valid UTF-8".to_owned(),
                });
            };
            let uri = percent_encode(bin_name);
            check(path, &file_opts)?;
            check(&bin_path, &file_opts)?;
            let (json, bin, summary) = to_gltf(h, opts, &uri).map_err(|e| output_error(e, &name))?;
            write_file(&bin_path, &file_opts, &bin)?;
            write_file(path, &file_opts, &json)?;
            Ok(summary)
        }
        None => Err(Error::Unsupported {
            file: name,
            message: "the output must end in .glb (binary glTF) or .gltf (JSON plus .bin)".to_owned(),
        }),
    }
}

/// A file name as a relative URI: bytes outside the unreserved set are percent-encoded.
fn percent_encode(name: &str) -> String {
    let mut out = String::with_capacity(name.len());
    for b in name.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            let _ = write!(out, "%{b:02X}");
        }
    }
    out
}

fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io { file: path.display().to_string(), source }
}

/// Refuses, before any work, an output that cannot be written (a folder, a missing folder, an
/// existing file with `no_clobber`).
fn check(path: &Path, opts: &octowrap_fsutil::WriteOptions) -> Result<(), Error> {
    octowrap_fsutil::check_output(path, opts).map_err(|e| io_error(path, e))
}

fn write_file(path: &Path, opts: &octowrap_fsutil::WriteOptions, bytes: &[u8]) -> Result<(), Error> {
    octowrap_fsutil::write_file(path, opts, |w| w.write_all(bytes))
        .map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| io_error(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn containers_and_uris() {
        assert_eq!(Container::from_path(Path::new("a/B.GLB")), Some(Container::Glb));
        assert_eq!(Container::from_path(Path::new("b.gltf")), Some(Container::Gltf));
        assert_eq!(Container::from_path(Path::new("c.obj")), None);
        assert_eq!(percent_encode("my model #1.bin"), "my%20model%20%231.bin");
    }

    #[test]
    fn unsupported_extension_names_the_file() {
        let e = write_path(Path::new("out.fbx"), &Hierarchy::default(), &ExportOptions::default()).unwrap_err();
        assert!(matches!(e, Error::Unsupported { .. }));
        assert!(e.to_string().starts_with("out.fbx: unsupported"), "{e}");
    }
}
