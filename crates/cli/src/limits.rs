//! `--max-memory`: the ceiling on what one input may make the command allocate, and the one place
//! where it reaches the readers and the MRQ decoder.

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Context, bail};

/// The default of `--max-memory`.
pub const DEFAULT_MAX_MEMORY: &str = "16G";

static MAX_MEMORY: OnceLock<u64> = OnceLock::new();
static MAX_SCANS: OnceLock<u64> = OnceLock::new();

/// Records `--max-scans` for the whole run (the first call wins).
pub fn set_max_scans(n: u64) {
    let _ = MAX_SCANS.set(n);
}

/// Records `--max-memory` for the whole run (the first call wins).
pub fn set_max_memory(bytes: u64) {
    let _ = MAX_MEMORY.set(bytes);
}

/// `--max-memory` in bytes.
pub fn max_memory() -> u64 {
    *MAX_MEMORY.get().unwrap_or(&(16 << 30))
}

/// Parses a size: a number of bytes with an optional binary suffix (`K`, `M`, `G`, `T`, with or
/// without `iB`/`B`, any case): `512M`, `8G`, `1.5GiB`, `1000000`.
pub fn parse_size(s: &str) -> anyhow::Result<u64> {
    let t = s.trim();
    let lower = t.to_ascii_lowercase();
    let body = lower.strip_suffix("ib").or_else(|| lower.strip_suffix('b')).unwrap_or(&lower);
    let (num, shift) = match body.chars().last() {
        Some('k') => (&body[..body.len() - 1], 10),
        Some('m') => (&body[..body.len() - 1], 20),
        Some('g') => (&body[..body.len() - 1], 30),
        Some('t') => (&body[..body.len() - 1], 40),
        _ => (body, 0),
    };
    let v: f64 = num.trim().parse().with_context(|| format!("'{s}' is not a size (for example 512M, 8G)"))?;
    let bytes = v * f64::from(1u32 << (shift / 2)) * f64::from(1u32 << (shift - shift / 2));
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < 2f64.powi(63)) {
        bail!("'{s}' is not a size between 1 byte and 8 EiB");
    }
    Ok(bytes as u64)
}

/// Refuses an input file larger than `--max-memory` before reading it.
pub fn check_input_size(path: &Path) -> anyhow::Result<()> {
    if path == Path::new("-") {
        return Ok(());
    }
    let max = max_memory();
    if let Ok(m) = std::fs::metadata(path) {
        if m.is_file() && m.len() > max {
            bail!(
                "{}: the file is {} bytes, more than --max-memory ({max} bytes): raise --max-memory to read it",
                path.display(),
                m.len()
            );
        }
    }
    Ok(())
}

/// The readers' options with `--max-memory` applied.
pub fn read_options(mut o: octowrap_io::ReadOptions) -> octowrap_io::ReadOptions {
    let max = max_memory();
    o.limits.max_memory = Some(max);
    o.limits.max_scans = *MAX_SCANS.get().unwrap_or(&octowrap_io::Limits::DEFAULT_MAX_SCANS);
    o
}

/// The MRQ decoder's limits with `--max-memory` applied.
pub fn format_limits() -> octowrap_format::Limits {
    let mut l = octowrap_format::Limits::default();
    l.max_level_bytes = l.max_level_bytes.min(max_memory());
    l
}

/// The MRQ decoder's options: levels `0..=level` (all when `None`), `--max-memory` applied.
pub fn decode_options(level: Option<u32>) -> octowrap_format::DecodeOptions {
    let mut o = octowrap_format::DecodeOptions::default();
    o.limits = format_limits();
    o.max_level = level;
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("8g").unwrap(), 8 << 30);
        assert_eq!(parse_size("1.5GiB").unwrap(), 3 << 29);
        assert_eq!(parse_size("1000").unwrap(), 1000);
        assert_eq!(parse_size("2kb").unwrap(), 2048);
        assert!(parse_size("0").is_err());
        assert!(parse_size("-1G").is_err());
        assert!(parse_size("lots").is_err());
        assert!(parse_size("99999999T").is_err());
    }
}
