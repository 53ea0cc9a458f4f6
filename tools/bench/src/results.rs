//! The results page, `tools/bench/RESULTS.md`: one current table per area, written by the bench
//! (ripgrep's `benchsuite/runs` keeps raw runs beside a page the same way).
//!
//! `-- AREA --write-results` runs one area, replaces that area's block on the page (between its
//! `<!-- bench:AREA -->` markers), keeps the other areas' blocks as they are, and writes the run's
//! full output to `runs/DATE-AREA.txt`. A block names the command, date, commit (with `dirty`
//! when tracked files other than the page and the runs differ from it), machine and load; its
//! rows are the figures the section reported with [`crate::util::headline`].

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::{Capture, Headline};

/// The areas in page order: key (the section name on the command line) and title.
pub const AREAS: &[(&str, &str)] = &[
    ("io", "I/O: PLY read and write"),
    ("recon", "Reconstruction"),
    ("format", "Format: MRQ at 12-bit quantization"),
    ("chunks", "Chunks: size, bytes read by a view, decode speed (format version 5)"),
    ("accuracy", "Accuracy: MRQ on decoder lines against free positions"),
    ("validate", "Validator"),
    ("decimate", "Decimation"),
    ("tiles", "3D Tiles export"),
    ("browser", "Browser: the MRQ viewer page and its WebAssembly decoder"),
    ("fuzz", "Fuzzing: the last tools/fuzz campaign"),
    ("python", "Python package: `import octowrap` against the library and the command line"),
    ("hostile", "Hostile input: issue 17's table re-run"),
];

/// The page's opening, before the areas' blocks.
const HEADER: &str = "# Benchmark results

The current figures, one table per area, each written by the bench itself:
`cargo run --release -p octowrap-bench -- AREA --write-results` runs one area, replaces its table
here (keeping the other areas') and writes the run's full output to `runs/DATE-AREA.txt`. What
the figures mean and why a target stands where it does: `docs/decisions.md`, section Benchmarks.
Earlier figures: the history of this file and of `runs/`.
";

/// Where and when a section ran.
#[derive(Debug)]
pub struct RunInfo {
    /// The command that reproduces the run.
    pub command: String,
    /// `YYYY-MM-DD HH:MM UTC` at the start.
    pub when: String,
    /// Short commit hash, with ` (dirty)` when the tree differs from it.
    pub commit: String,
    /// [`crate::util::machine_line`].
    pub machine: String,
    /// One-minute load average at the start and at the end of the section.
    pub load: (Option<f64>, Option<f64>),
    /// Cores available.
    pub cores: usize,
}

impl RunInfo {
    /// The run of section `area` starting now; `load` at its start.
    pub fn start(area: &str) -> Self {
        let mut vars = String::new();
        for (k, v) in std::env::vars().filter(|(k, _)| k.starts_with("OCTOWRAP_") && k != "OCTOWRAP_DATA") {
            let _ = write!(vars, "{k}={v} ");
        }
        Self {
            command: format!("{vars}cargo run --release -p octowrap-bench -- {area} --write-results"),
            when: utc_now(),
            commit: commit(),
            machine: crate::util::machine_line(),
            load: (crate::util::load_average(), None),
            cores: crate::util::cores(),
        }
    }

    /// Whether other work shared the machine: a load above one before the section started
    /// (the bench's own threads come later), or above the cores plus one at its end.
    fn noisy(&self) -> bool {
        self.load.0.is_some_and(|l| l > 1.0) || self.load.1.is_some_and(|l| l > self.cores as f64 + 1.0)
    }

    fn load_text(&self) -> String {
        let f = |l: Option<f64>| l.map_or_else(|| "?".to_owned(), |l| format!("{l:.1}"));
        let noise = if self.noisy() {
            ": **noisy**, other jobs shared the machine; to be rerun on a quiet one"
        } else {
            ": quiet"
        };
        format!("load average {} at the start, {} at the end{noise}", f(self.load.0), f(self.load.1))
    }
}

/// `git rev-parse --short HEAD`, with ` (dirty)` when tracked files other than the results page
/// and the raw runs differ from it; `unknown` outside a git checkout.
fn commit() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let git = |args: &[&str]| {
        Command::new("git")
            .arg("-C")
            .arg(&root)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
    };
    let Some(hash) = git(&["rev-parse", "--short", "HEAD"]) else { return "unknown".to_owned() };
    let status = git(&[
        "status",
        "--porcelain",
        "--untracked-files=no",
        "--",
        ".",
        ":(exclude)tools/bench/RESULTS.md",
        ":(exclude)tools/bench/runs",
    ]);
    match status {
        Some(s) if s.is_empty() => hash,
        Some(_) => format!("{hash} (dirty)"),
        None => format!("{hash} (status unknown)"),
    }
}

/// The current time as `YYYY-MM-DD HH:MM UTC`.
fn utc_now() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (y, m, d) = civil_from_days((secs / 86_400) as i64);
    format!("{y:04}-{m:02}-{d:02} {:02}:{:02} UTC", secs % 86_400 / 3600, secs % 3600 / 60)
}

/// The proleptic Gregorian date of a day count since 1970-01-01 (Howard Hinnant's
/// `civil_from_days`, chrono-compatible algorithms).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// The page's folder.
fn bench_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Writes the raw run and replaces the area's block on the page; returns the raw file's path.
pub fn write(area: &str, info: &RunInfo, capture: &Capture) -> std::io::Result<PathBuf> {
    let dir = bench_dir();
    let raw_name = format!("runs/{}-{area}.txt", &info.when[..10]);
    let raw_path = dir.join(&raw_name);
    std::fs::create_dir_all(dir.join("runs"))?;
    let raw = format!(
        "command: {}\nrun: {}, commit {}, {}\n{}\n\n{}",
        info.command,
        info.when,
        info.commit,
        info.machine,
        info.load_text(),
        capture.text
    );
    std::fs::write(&raw_path, raw)?;
    let page_path = dir.join("RESULTS.md");
    let old = std::fs::read_to_string(&page_path).unwrap_or_default();
    let block = block(area, info, &capture.headlines, &raw_name);
    std::fs::write(&page_path, page(&old, area, &block))?;
    Ok(raw_path)
}

/// The page with `area`'s block replaced by `block` (the header and the other areas' blocks kept,
/// in [`AREAS`] order; text outside the blocks is the bench's header).
fn page(old: &str, area: &str, block: &str) -> String {
    let mut out = String::from(HEADER);
    for &(key, _) in AREAS {
        let text = if key == area { Some(block.to_owned()) } else { existing_block(old, key) };
        if let Some(t) = text {
            out.push('\n');
            out.push_str(&t);
        }
    }
    out
}

fn markers(key: &str) -> (String, String) {
    (format!("<!-- bench:{key} -->"), format!("<!-- /bench:{key} -->"))
}

/// An area's block on the page, markers included.
fn existing_block(page: &str, key: &str) -> Option<String> {
    let (open, close) = markers(key);
    let start = page.find(&open)?;
    let end = page[start..].find(&close)? + start + close.len();
    Some(format!("{}\n", &page[start..end]))
}

/// An area's block: title, the run's line, the table of headline figures.
fn block(area: &str, info: &RunInfo, rows: &[Headline], raw_name: &str) -> String {
    let title = AREAS.iter().find(|a| a.0 == area).map_or(area, |a| a.1);
    let (open, close) = markers(area);
    let mut s = format!("{open}\n## {title}\n\n");
    let _ = writeln!(s, "- command: `{}`", info.command);
    let _ = writeln!(s, "- run: {}, commit {}, {}", info.when, info.commit, info.machine);
    let _ = writeln!(s, "- {}", info.load_text());
    let _ = writeln!(s, "- full output: [{raw_name}]({raw_name})\n");
    s.push_str("| case | figure | target | |\n|---|---|---|---|\n");
    if rows.is_empty() {
        s.push_str("| (no figures: see the full output) | | | |\n");
    }
    for h in rows {
        let verdict = match h.met {
            Some(true) => "met",
            Some(false) => "**NOT met**",
            None => "",
        };
        let _ = writeln!(s, "| {} | {} | {} | {verdict} |", h.case, h.figure, h.target);
    }
    let _ = writeln!(s, "{close}");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info() -> RunInfo {
        RunInfo {
            command: "cargo run".to_owned(),
            when: "2026-12-03 08:00 UTC".to_owned(),
            commit: "abc1234".to_owned(),
            machine: "machine: 2 cores, X".to_owned(),
            load: (Some(0.2), Some(2.1)),
            cores: 2,
        }
    }

    #[test]
    fn dates_from_day_counts() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(20_790), (2026, 12, 3));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
    }

    #[test]
    fn an_area_replaces_its_block_and_keeps_the_others() {
        let row = |case: &str| Headline {
            case: case.to_owned(),
            figure: "1 s".to_owned(),
            target: "2 s".to_owned(),
            met: Some(true),
        };
        let io = block("io", &info(), &[row("read")], "runs/x-io.txt");
        let dec = block("decimate", &info(), &[row("collapse")], "runs/x-decimate.txt");
        // Areas land in page order whatever the order they are written in; old notebook text
        // outside the blocks is dropped.
        let p1 = page("# old notebook\n\nsession notes\n", "decimate", &dec);
        assert!(!p1.contains("session notes"));
        let p2 = page(&p1, "io", &io);
        assert!(p2.starts_with(HEADER));
        assert!(p2.find("## I/O").unwrap() < p2.find("## Decimation").unwrap());
        assert!(p2.contains("| collapse | 1 s | 2 s | met |"));
        // Rewriting io replaces its rows only.
        let io2 = block("io", &info(), &[row("write")], "runs/y-io.txt");
        let p3 = page(&p2, "io", &io2);
        assert!(p3.contains("| write |") && !p3.contains("| read |") && p3.contains("| collapse |"));
        assert_eq!(p3.matches("<!-- bench:io -->").count(), 1);
        assert_eq!(page(&p3, "io", &io2), p3);
    }

    #[test]
    fn a_loaded_machine_is_called_noisy() {
        let mut i = info();
        assert!(!i.noisy());
        i.load.0 = Some(3.5);
        assert!(i.noisy() && i.load_text().contains("noisy"));
    }
}
