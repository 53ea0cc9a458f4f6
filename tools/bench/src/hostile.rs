//! Hostile input (issue 17): re-runs the table. Every class of the table gets several
//! files crafted here, in a temporary folder, of the kinds the issue describes; the built
//! `octowrap` binary runs on each, and each row records the exit status, the wall time and the
//! child's peak resident memory, and whether the outcome is the wanted one.
//!
//! Each run has a time cap and a memory cap: the child's `/proc/PID/status` is read every 2 ms
//! (`VmHWM`, the kernel's own peak of the resident set, and `VmRSS`), and the child is killed when
//! it passes either cap, so a regression shows as a row that is not wanted instead of a bench that
//! hangs or takes the machine's memory. The peak is the last `VmHWM` read before the child exits
//! (a child that lives less than one sampling period shows `<2 ms`).
//!
//! The binary is `target/release/octowrap` (`cargo build --release -p octowrap-cli` first), or
//! the one `OCTOWRAP_BIN` names. `OCTOWRAP_HOSTILE=WORD` runs only the classes whose name holds
//! WORD (`OCTOWRAP_HOSTILE=super`: the super-linear class).

use std::ffi::OsStr;
use std::fmt::Write as _;
use std::io::Write as _;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::util::headline;

/// The caps of one run.
#[derive(Clone, Copy, Debug)]
struct Cap {
    secs: f64,
    mib: u64,
}

/// The default caps: far above what any wanted outcome needs, far below a hang or a bomb.
const CAP: Cap = Cap { secs: 30.0, mib: 2048 };

/// What one run of the binary did.
#[derive(Debug, Default)]
struct Run {
    /// Exit code (`None`: killed by a signal).
    code: Option<i32>,
    /// The signal that ended it, if any.
    signal: Option<i32>,
    secs: f64,
    /// Peak resident set in KiB (`VmHWM`), if it was sampled.
    peak_kib: Option<u64>,
    /// Which cap killed it, if one did.
    capped: Option<&'static str>,
    stdout: Vec<u8>,
    stderr: String,
}

impl Run {
    fn stdout_text(&self) -> String {
        String::from_utf8_lossy(&self.stdout).into_owned()
    }

    /// Both streams, lower case.
    fn all_lower(&self) -> String {
        format!("{}\n{}", self.stdout_text(), self.stderr).to_lowercase()
    }

    fn peak_mib(&self) -> f64 {
        self.peak_kib.map_or(0.0, |k| k as f64 / 1024.0)
    }

    /// The exit, as the table shows it.
    fn exit(&self) -> String {
        match (self.capped, self.code, self.signal) {
            (Some(c), _, _) => format!("killed ({c})"),
            (None, Some(c), _) => c.to_string(),
            (None, None, Some(s)) => format!("signal {s}"),
            _ => "?".to_owned(),
        }
    }

    /// The run ended by itself, without a panic or an abort.
    fn clean(&self) -> Result<(), String> {
        if let Some(c) = self.capped {
            return Err(format!("killed at the {c}"));
        }
        if self.stderr.contains("panicked") || self.code == Some(101) {
            return Err(format!("panic: {}", first_line(&self.stderr)));
        }
        if self.signal.is_some() || self.code == Some(134) {
            return Err(format!("aborted: {}", first_line(&self.stderr)));
        }
        Ok(())
    }

    /// A clean refusal: exit 1 or 2 with an error message holding every one of `needles`
    /// (case-insensitive).
    fn refused(&self, needles: &[&str]) -> Result<(), String> {
        self.clean()?;
        if self.code == Some(0) {
            return Err("accepted (exit 0)".to_owned());
        }
        let err = self.stderr.to_lowercase();
        for n in needles {
            if !err.contains(&n.to_lowercase()) {
                return Err(format!("the message lacks '{n}': {}", first_line(&self.stderr)));
            }
        }
        Ok(())
    }

    /// Exit 0.
    fn ok(&self) -> Result<(), String> {
        self.clean()?;
        if self.code == Some(0) { Ok(()) } else { Err(format!("failed: {}", first_line(&self.stderr))) }
    }

    fn within(&self, secs: f64, mib: f64) -> Result<(), String> {
        if self.secs > secs {
            return Err(format!("took {:.2} s, more than {secs} s", self.secs));
        }
        if self.peak_mib() > mib {
            return Err(format!("peak {:.0} MiB, more than {mib} MiB", self.peak_mib()));
        }
        Ok(())
    }
}

fn first_line(s: &str) -> String {
    let l = s.lines().find(|l| !l.trim().is_empty()).unwrap_or("").trim();
    if l.chars().count() > 110 { format!("{}…", l.chars().take(110).collect::<String>()) } else { l.to_owned() }
}

/// One row of the table.
struct Row {
    case: String,
    exit: String,
    secs: f64,
    peak: String,
    verdict: Result<(), String>,
}

/// A class of the table, and the function that probes it.
type Class = (&'static str, fn(&mut Ctx));

/// The probe's folder and binary, and the rows so far.
struct Ctx {
    bin: PathBuf,
    dir: tempfile::TempDir,
    rows: Vec<(&'static str, Row)>,
    class: &'static str,
}

fn s(p: &Path) -> &str {
    p.to_str().expect("the probe's temporary paths are UTF-8")
}

/// The peak (`VmHWM`) and current (`VmRSS`) resident set of `pid`, in KiB.
fn memory_of(pid: u32) -> Option<(u64, u64)> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let field = |name: &str| -> Option<u64> {
        status.lines().find(|l| l.starts_with(name))?.split_whitespace().nth(1)?.parse().ok()
    };
    Some((field("VmHWM:")?, field("VmRSS:")?))
}

impl Ctx {
    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.path(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).expect("the probe's folder is writable");
        }
        std::fs::write(&p, bytes).expect("the probe's folder is writable");
        p
    }

    fn command(&self, args: &[&str]) -> Command {
        let mut c = Command::new(&self.bin);
        c.args(args).current_dir(self.dir.path()).stdin(Stdio::null());
        c
    }

    /// Runs the binary with `args` under `cap`.
    fn run(&self, args: &[&str], cap: Cap) -> Run {
        self.run_command(self.command(args), cap, false)
    }

    /// Runs `cmd` under `cap`, its output captured in files (or, with `closed_stdout`, its
    /// standard output a pipe whose reading end is closed at once, as `| head -1` does).
    fn run_command(&self, mut cmd: Command, cap: Cap, closed_stdout: bool) -> Run {
        static SEQ: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let k = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let (out_path, err_path) = (self.path(&format!(".run{k}.out")), self.path(&format!(".run{k}.err")));
        let out_file = std::fs::File::create(&out_path).expect("writable");
        let err_file = std::fs::File::create(&err_path).expect("writable");
        if closed_stdout {
            cmd.stdout(Stdio::piped());
        } else {
            cmd.stdout(out_file);
        }
        cmd.stderr(err_file);
        let start = Instant::now();
        let mut child = match cmd.spawn() {
            Ok(c) => c,
            Err(e) => return Run { stderr: format!("cannot start: {e}"), code: Some(-1), ..Run::default() },
        };
        if closed_stdout {
            drop(child.stdout.take());
        }
        let mut run = Run::default();
        let status = loop {
            match child.try_wait() {
                Ok(Some(st)) => break st,
                Ok(None) => {}
                Err(e) => {
                    run.stderr = format!("cannot wait: {e}");
                    return run;
                }
            }
            if let Some((hwm, rss)) = memory_of(child.id()) {
                run.peak_kib = Some(run.peak_kib.unwrap_or(0).max(hwm));
                if rss > cap.mib * 1024 && run.capped.is_none() {
                    run.capped = Some("memory cap");
                    let _ = child.kill();
                }
            }
            if start.elapsed().as_secs_f64() > cap.secs && run.capped.is_none() {
                run.capped = Some("time cap");
                let _ = child.kill();
            }
            std::thread::sleep(Duration::from_millis(2));
        };
        run.secs = start.elapsed().as_secs_f64();
        run.code = status.code();
        run.signal = std::os::unix::process::ExitStatusExt::signal(&status);
        run.stdout = std::fs::read(&out_path).unwrap_or_default();
        run.stderr = String::from_utf8_lossy(&std::fs::read(&err_path).unwrap_or_default()).into_owned();
        let _ = std::fs::remove_file(out_path);
        let _ = std::fs::remove_file(err_path);
        run
    }

    /// Records a row for `run` with `verdict`.
    fn row(&mut self, case: impl Into<String>, run: &Run, verdict: Result<(), String>) {
        let peak = match run.peak_kib {
            Some(k) => format!("{:.0}", k as f64 / 1024.0),
            None => "<2 ms".to_owned(),
        };
        let row = Row { case: case.into(), exit: run.exit(), secs: run.secs, peak, verdict };
        self.rows.push((self.class, row));
    }

    /// Records a row that is not one run (several runs, or a check of files).
    fn note(&mut self, case: impl Into<String>, secs: f64, verdict: Result<(), String>) {
        let row = Row { case: case.into(), exit: "–".to_owned(), secs, peak: "–".to_owned(), verdict };
        self.rows.push((self.class, row));
    }
}

/// Both results fine: the first error otherwise.
fn all(checks: impl IntoIterator<Item = Result<(), String>>) -> Result<(), String> {
    checks.into_iter().collect::<Result<Vec<()>, String>>().map(|_| ())
}

/// A small deterministic generator (the same files on every run).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        self.0 >> 11
    }

    fn unit(&mut self) -> f64 {
        self.next() as f64 / (1u64 << 53) as f64
    }

    fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| (self.next() >> 17) as u8).collect()
    }
}

/// An XYZ text of `n` points in the unit cube.
fn unit_cube_xyz(n: usize, seed: u64) -> String {
    let mut r = Lcg(seed);
    let mut s = String::new();
    for _ in 0..n {
        let _ = writeln!(s, "{:.6} {:.6} {:.6}", r.unit(), r.unit(), r.unit());
    }
    s
}

/// An XYZ text of `n` points on the unit sphere (a surface the reconstruction can wrap).
fn sphere_xyz(n: usize) -> String {
    let mut s = String::new();
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let t = golden * i as f64;
        let _ = writeln!(s, "{:.6} {:.6} {:.6}", r * t.cos(), r * t.sin(), z);
    }
    s
}

/// A binary PLY header for `n` float vertices.
fn ply_header(n: u64) -> Vec<u8> {
    format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
    )
    .into_bytes()
}

/// `payload` then `zeros` zero bytes, gzip-compressed (fast level: zeros compress anyway).
fn gzip_with_zeros(payload: &[u8], zeros: usize) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(payload).expect("in memory");
    let block = vec![0u8; 1 << 20];
    let mut left = zeros;
    while left > 0 {
        let n = left.min(block.len());
        e.write_all(&block[..n]).expect("in memory");
        left -= n;
    }
    e.finish().expect("in memory")
}

/// `line` repeated `times` times, gzip-compressed.
fn gzip_repeated(line: &[u8], times: usize) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    let chunk = line.repeat(65_536);
    let mut left = times;
    while left > 0 {
        let n = left.min(65_536);
        e.write_all(&chunk[..n * line.len()]).expect("in memory");
        left -= n;
    }
    e.finish().expect("in memory")
}

fn gzip(payload: &[u8]) -> Vec<u8> {
    gzip_with_zeros(payload, 0)
}

/// A closed quad mesh: the cube of `fixtures/meshes/valid/cube_quads.obj`.
const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

pub fn report() {
    outln!("## Hostile input (issue 17)\n");
    let Some(bin) = crate::util::octowrap_binary() else {
        outln!("no octowrap binary: `cargo build --release -p octowrap-cli` first (or set OCTOWRAP_BIN)\n");
        headline("hostile input", "not measured: no octowrap binary", "every row wanted", None);
        return;
    };
    let dir = tempfile::Builder::new().prefix("octowrap-hostile-").tempdir().expect("a temporary folder");
    let mut ctx = Ctx { bin, dir, rows: Vec::new(), class: "" };
    let started = Instant::now();
    let classes: [Class; 10] = [
        ("declared counts in MRQ", mrq_counts),
        ("decompression bombs", bombs),
        ("amplification", amplification),
        ("super-linear work", super_linear),
        ("nonsense accepted", nonsense),
        ("writes that harm", writes),
        ("streams", streams),
        ("options", options),
        ("messages", messages),
        ("memory ceiling", ceiling),
    ];
    outln!(
        "`{}` on files crafted in a temporary folder; caps per run (killed past them): {} s and",
        ctx.bin.display(),
        CAP.secs
    );
    outln!("{} MiB unless a row says otherwise. Peak = the child's `VmHWM`, sampled every 2 ms.\n", CAP.mib);
    let only = std::env::var("OCTOWRAP_HOSTILE").unwrap_or_default();
    for (class, f) in classes {
        if !class.contains(only.as_str()) {
            continue;
        }
        ctx.class = class;
        let t = Instant::now();
        f(&mut ctx);
        let rows: Vec<&Row> = ctx.rows.iter().filter(|r| r.0 == class).map(|r| &r.1).collect();
        let wanted = rows.iter().filter(|r| r.verdict.is_ok()).count();
        outln!("### {class}: {wanted} of {} rows wanted ({:.1} s)\n", rows.len(), t.elapsed().as_secs_f64());
        outln!("| case | exit | seconds | peak MiB | outcome |");
        outln!("|---|---|---|---|---|");
        for r in &rows {
            let outcome = match &r.verdict {
                Ok(()) => "wanted".to_owned(),
                Err(e) => format!("**NOT wanted**: {}", e.replace('|', "\\|")),
            };
            outln!("| {} | {} | {:.3} | {} | {outcome} |", r.case.replace('|', "\\|"), r.exit, r.secs, r.peak);
        }
        outln!();
        headline(
            format!("hostile: {class}"),
            format!("{wanted} of {} rows wanted", rows.len()),
            "all",
            Some(wanted == rows.len()),
        );
    }
    let total = ctx.rows.len();
    let wanted = ctx.rows.iter().filter(|r| r.1.verdict.is_ok()).count();
    outln!(
        "{wanted} of {total} rows wanted, in {:.0} s (load {:.1}).\n",
        started.elapsed().as_secs_f64(),
        crate::util::load_average().unwrap_or(f64::NAN)
    );
}

/// MRQ files whose level table declares huge counts, with valid checksums, through every
/// command that reads MRQ.
fn mrq_counts(ctx: &mut Ctx) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let seeds = ["cube3_lattice_q12.mrq", "v3_cube3_generic_q12.mrq", "two_level_quad_q4.mrq", "polygon_soup_q16.mrq"];
    let counts: [(&str, (u32, u32, u32)); 4] = [
        ("2^28 vertices", (1 << 28, 0, 0)),
        ("2^28 faces", (0, 1 << 28, 0)),
        ("2^31 corners", (0, 0, 1 << 31)),
        ("u32::MAX everything", (u32::MAX, u32::MAX, u32::MAX)),
    ];
    let mut files = Vec::new();
    for (i, seed) in seeds.iter().enumerate() {
        let Ok(bytes) = std::fs::read(root.join("fixtures/format/valid").join(seed)) else { continue };
        let Some(p) = octowrap_format::fuzzing::payloads(&bytes) else { continue };
        let (name, (v, f, c)) = counts[i % counts.len()];
        // Every level's counts raised (the real count where the override is 0).
        let Ok(info) = octowrap_format::read_info(&bytes[..], &octowrap_format::Limits::default()) else { continue };
        let table: Vec<(u32, u32, u32)> = info
            .levels
            .iter()
            .map(|l| {
                let pick = |o: u32, real: u32| if o == 0 { real } else { o };
                (pick(v, l.vertex_count), pick(f, l.face_count), pick(c, l.corner_count))
            })
            .collect();
        let Some(file) = octowrap_format::fuzzing::reseal(&bytes, &p, Some(&table)) else { continue };
        files.push((format!("{seed} with {name}"), ctx.write(&format!("counts{i}.mrq"), file)));
    }
    if files.is_empty() {
        ctx.note("no MRQ fixture could be resealed", 0.0, Err("fixtures/format/valid unreadable".to_owned()));
        return;
    }
    for (name, file) in &files {
        let f = s(file);
        let runs: [(&str, Vec<&str>); 6] = [
            ("convert", vec!["convert", f, "counts-out.ply"]),
            ("validate", vec!["validate", f]),
            ("extract", vec!["extract", f, "-o", "counts-out.obj"]),
            ("export", vec!["export", f, "-o", "counts-out.glb"]),
            ("decimate", vec!["decimate", f, "--ratio", "0.5", "-o", "counts-out.obj"]),
            ("info", vec!["info", f]),
        ];
        for (cmd, args) in runs {
            let run = ctx.run(&args, CAP);
            let name_of = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let verdict = all([run.refused(&[&name_of]), run.within(5.0, 256.0)]);
            // `info` reads the table only: it may list the declared counts and succeed.
            let verdict = if cmd == "info" { all([run.clean(), run.within(5.0, 256.0)]) } else { verdict };
            ctx.row(format!("`{cmd}` {name}"), &run, verdict);
        }
    }
}

/// gzip and zstd streams that expand far past what their header declares.
fn bombs(ctx: &mut Ctx) {
    let mut body = ply_header(1000);
    body.extend(std::iter::repeat_n(0u8, 12_000));
    let gib = 1usize << 30;
    let trailing = ctx.write("trailing.ply.gz", gzip_with_zeros(&body, gib));
    let big_decl = ctx.write("declares.ply.gz", gzip_with_zeros(&ply_header(1 << 31), gib));
    let mid_decl = ctx.write("declares-100m.ply.gz", gzip_with_zeros(&ply_header(100_000_000), gib / 4));
    let xyz_gz = ctx.write("points.xyz.gz", gzip_repeated(b"0 0 0\n", 60_000_000));
    let mut garbage = gzip(CUBE_OBJ.as_bytes());
    garbage.extend_from_slice(b"this is not gzip: trailing garbage after the member");
    let garbage = ctx.write("garbage.obj.gz", garbage);
    for (case, file, needles) in [
        ("`info` .ply.gz: 1,000 vertices then 1 GiB of zeros", &trailing, vec!["trailing"]),
        ("`info` .ply.gz declaring 2^31 vertices over 1 GiB of zeros", &big_decl, vec!["declares.ply.gz"]),
        ("`convert` .obj.gz with garbage after the gzip member", &garbage, vec!["garbage.obj.gz"]),
    ] {
        let args: Vec<&str> =
            if case.starts_with("`info`") { vec!["info", s(file)] } else { vec!["convert", s(file), "g.ply"] };
        let run = ctx.run(&args, CAP);
        ctx.row(case, &run, all([run.refused(&needles), run.within(20.0, 300.0)]));
    }
    let run = ctx.run(&["reconstruct", s(&trailing), "-o", "t.mrq"], CAP);
    ctx.row(
        "`reconstruct` .ply.gz: 1,000 vertices then 1 GiB of zeros",
        &run,
        all([run.refused(&["trailing"]), run.within(20.0, 300.0)]),
    );
    for (case, file) in [
        ("`info --max-memory 256M` .ply.gz declaring 10^8 vertices over 256 MiB of zeros", &mid_decl),
        ("`info --max-memory 256M` .xyz.gz of 60 M points (360 MB of text)", &xyz_gz),
    ] {
        let run = ctx.run(&["info", "--max-memory", "256M", s(file)], CAP);
        ctx.row(case, &run, all([run.refused(&["max-memory"]), run.within(20.0, 300.0)]));
    }
    let run = ctx.run(&["info", "--max-memory", "16M", s(&xyz_gz)], CAP);
    ctx.row(
        "`info --max-memory 16M` the same .xyz.gz",
        &run,
        all([run.refused(&["max-memory"]), run.within(20.0, 100.0)]),
    );
    // MRQ levels whose zstd frame expands hugely.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let Ok(seed) = std::fs::read(root.join("fixtures/format/valid/cube3_lattice_q12.mrq")) else {
        ctx.note("MRQ zstd bombs", 0.0, Err("fixtures/format/valid/cube3_lattice_q12.mrq unreadable".to_owned()));
        return;
    };
    let zeros = vec![0u8; gib];
    let frame = zstd::bulk::compress(&zeros, 19).expect("zstd in memory");
    drop(zeros);
    for (case, raw, args) in [
        ("`convert` MRQ level: 1 GiB zstd frame, table says 4 KiB", 4096u64, vec!["convert", "ZB", "z.ply"]),
        ("`convert` MRQ level: 1 GiB zstd frame, table says 1 GiB", gib as u64, vec!["convert", "ZB", "z.ply"]),
        (
            "`validate --max-memory 256M` MRQ level: 1 GiB zstd frame, table says 1 GiB",
            gib as u64,
            vec!["validate", "--max-memory", "256M", "ZB"],
        ),
        ("`extract` MRQ level: 1 GiB zstd frame, table says 2^40", 1u64 << 40, vec!["extract", "ZB", "-o", "z.obj"]),
    ] {
        let Some(file) = octowrap_format::tamper::replace_stored(&seed, 0, &frame, raw) else { continue };
        let p = ctx.write(&format!("zbomb{raw}.mrq"), file);
        let args: Vec<&str> = args.iter().map(|a| if *a == "ZB" { s(&p) } else { a }).collect();
        let run = ctx.run(&args, CAP);
        ctx.row(
            format!("{case} ({} KB file)", std::fs::metadata(&p).map_or(0, |m| m.len()) / 1000),
            &run,
            all([run.refused(&[]), run.within(10.0, 600.0)]),
        );
    }
}

/// `.conf` scan sets whose lines name one scan many times.
fn amplification(ctx: &mut Ctx) {
    ctx.write("amp/scan.xyz", unit_cube_xyz(3000, 7));
    let mut conf = String::from("camera 0 0 0 0 0 0 1\n");
    for _ in 0..60_000 {
        conf.push_str("bmesh scan.xyz 0 0 0 0 0 0 1\n");
    }
    let big = ctx.write("amp/many.conf", &conf);
    let mut selfref = String::from("camera 0 0 0 0 0 0 1\n");
    for _ in 0..50 {
        selfref.push_str("bmesh self.conf 0 0 0 0 0 0 1\n");
    }
    let selfref = ctx.write("amp/self.conf", selfref);
    let cameras =
        ctx.write("amp/cameras.conf", "camera 0 0 0 0 0 0 1\n".repeat(200_000) + "bmesh scan.xyz 0 0 0 0 0 0 1\n");
    let run = ctx.run(&["info", s(&big)], CAP);
    ctx.row(
        "`info` .conf: 60,000 `bmesh` lines naming one 3,000-point scan",
        &run,
        all([run.refused(&["max-scans"]), run.within(2.0, 100.0)]),
    );
    let run = ctx.run(&["reconstruct", s(&big), "-o", "amp.mrq"], CAP);
    ctx.row("`reconstruct` the same .conf", &run, all([run.refused(&["max-scans"]), run.within(2.0, 100.0)]));
    let run = ctx.run(&["info", "--max-scans", "100000", "--max-memory", "64M", s(&big)], CAP);
    ctx.row(
        "`info --max-scans 100000 --max-memory 64M` the same .conf",
        &run,
        all([run.refused(&["max-memory"]), run.within(10.0, 200.0)]),
    );
    let run = ctx.run(&["info", s(&selfref)], CAP);
    ctx.row("`info` .conf naming itself 50 times", &run, all([run.refused(&["self.conf"]), run.within(2.0, 100.0)]));
    let run = ctx.run(&["info", s(&cameras)], CAP);
    ctx.row(
        "`info` .conf: 200,000 `camera` lines, one scan (legitimate: read)",
        &run,
        all([run.ok(), run.within(5.0, 200.0)]),
    );
}

/// A polygon of `n` corners as OBJ, of one of the degenerate shapes.
fn polygon_obj(n: usize, shape: &str) -> String {
    let mut s = String::new();
    let distinct = match shape {
        "pairs" => n / 2,
        "laps" => n / 3,
        "point" => 1,
        _ => n,
    };
    for i in 0..distinct {
        let t = std::f64::consts::TAU * i as f64 / distinct as f64;
        let (x, y) = if shape == "collinear" { (i as f64, 0.0) } else { (t.cos(), t.sin()) };
        let _ = writeln!(s, "v {x:.9} {y:.9} 0");
    }
    s.push('f');
    for k in 0..n {
        let v = match shape {
            "pairs" => k / 2,
            "laps" => k % distinct,
            "point" => 0,
            _ => k,
        };
        let _ = write!(s, " {}", v + 1);
    }
    s.push('\n');
    s
}

/// Degenerate input to the decimator's polygon triangulation and the meshopt export.
fn super_linear(ctx: &mut Ctx) {
    let cap = Cap { secs: 60.0, mib: 2048 };
    for shape in ["pairs", "laps", "point", "collinear"] {
        let mut times = Vec::new();
        for n in [3000usize, 30_000, 300_000] {
            let p = ctx.write(&format!("poly-{shape}-{n}.obj"), polygon_obj(n, shape));
            let run = best_of_runs(ctx, &["decimate", s(&p), "--max-error", "1%", "-o", "poly-out.obj"], cap);
            let budget = n as f64 / 10_000.0 + 0.5;
            let ok_or_refused = if run.code == Some(0) { run.ok() } else { run.refused(&[]) };
            ctx.row(
                format!("`decimate --max-error 1%` one {n}-corner polygon, {}", shape_name(shape)),
                &run,
                all([ok_or_refused, run.within(budget, 1024.0)]),
            );
            times.push(run.secs);
        }
        growth(ctx, &format!("growth 3,000 → 30,000 corners ({})", shape_name(shape)), &times[..2], 10.0);
        growth(ctx, &format!("growth 30,000 → 300,000 corners ({})", shape_name(shape)), &times[1..], 10.0);
    }
    for (case, face) in [("`f 1 1 1`", "f 1 1 1\n"), ("`f 1 2 2`", "f 1 2 2\n"), ("one triangle repeated", "f 1 2 3\n")]
    {
        let mut times = Vec::new();
        for n in [60_000usize, 300_000] {
            let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
            obj.push_str(&face.repeat(n));
            let p = ctx.write(&format!("degenerate-{n}.obj"), obj);
            let run = best_of_runs(ctx, &["export", s(&p), "--meshopt", "-o", "degenerate.glb"], cap);
            let budget = if n == 60_000 { 3.0 } else { 15.0 };
            let ok_or_refused = if run.code == Some(0) { run.ok() } else { run.refused(&[]) };
            ctx.row(
                format!("`export --meshopt` {n} faces {case}"),
                &run,
                all([ok_or_refused, run.within(budget, 1024.0)]),
            );
            times.push(run.secs);
        }
        growth(ctx, &format!("growth 60,000 → 300,000 faces ({case})"), &times, 5.0);
    }
}

/// The fastest of three runs (one when the first takes over a second): the growth rows compare
/// times of a few milliseconds, which a loaded machine stretches at random.
fn best_of_runs(ctx: &Ctx, args: &[&str], cap: Cap) -> Run {
    let mut best = ctx.run(args, cap);
    for _ in 0..2 {
        if best.secs > 1.0 || best.capped.is_some() {
            break;
        }
        let again = ctx.run(args, cap);
        if again.secs < best.secs {
            best = again;
        }
    }
    best
}

fn shape_name(shape: &str) -> &'static str {
    match shape {
        "pairs" => "every corner twice in a row",
        "laps" => "three laps of one circle",
        "point" => "all corners one vertex",
        _ => "all corners on one line",
    }
}

/// A row for how the time grew from `times[0]` to `times[1]` when the input grew `factor`
/// times: wanted when the time grew at most `factor^1.3` times (a quadratic cost grows
/// `factor^2` times). The process start (about 5 ms) is taken off both, and times under 20 ms
/// count as 20 ms (below that the ratio measures the machine's noise).
fn growth(ctx: &mut Ctx, case: &str, times: &[f64], factor: f64) {
    let [a, b] = times else { return };
    let (a, b) = ((a - 0.005).max(0.02), (b - 0.005).max(0.02));
    let ratio = b / a;
    let limit = factor.powf(1.3);
    let verdict = if ratio <= limit {
        Ok(())
    } else {
        Err(format!("time grew {ratio:.1}× (limit {limit:.0}×; quadratic: {:.0}×)", factor * factor))
    };
    ctx.note(format!("{case}: {ratio:.1}×"), b, verdict);
}

/// Input that must be refused rather than produce a meaningless result.
fn nonsense(ctx: &mut Ctx) {
    for (name, extra) in [
        ("+1.7e308", "1.7e308 1.7e308 1.7e308\n"),
        ("-1.7e308", "-1.7e308 0.5 0.5\n"),
        ("±1.7e308 (two)", "1.7e308 0 0\n-1.7e308 0 0\n"),
        ("inf", "inf 0 0\n"),
    ] {
        let p = ctx.write(&format!("far-{}.xyz", name.len()), unit_cube_xyz(3000, 3) + extra);
        let run = ctx.run(&["reconstruct", s(&p), "-o", "far.mrq"], CAP);
        ctx.row(
            format!("`reconstruct` 3,000 points in the unit cube and one at {name}"),
            &run,
            all([run.refused(&["finite"]), run.within(10.0, 500.0)]),
        );
    }
    let mut r = Lcg(17);
    for k in 0..3 {
        let p = ctx.write(&format!("random{k}.obj"), r.bytes(100_000));
        let run = ctx.run(&["validate", "--require", "watertight", s(&p)], CAP);
        ctx.row(
            format!("`validate --require watertight` 100 KB of random bytes named .obj (#{k})"),
            &run,
            all([run.refused(&[]), run.within(5.0, 200.0)]),
        );
    }
    let p = ctx.write("random-info.obj", r.bytes(100_000));
    let run = ctx.run(&["info", s(&p)], CAP);
    ctx.row(
        "`info` 100 KB of random bytes named .obj",
        &run,
        all([run.refused(&["random-info.obj"]), run.within(5.0, 200.0)]),
    );
    let p = ctx.write("empty.obj", "");
    let run = ctx.run(&["validate", "--require", "watertight", s(&p)], CAP);
    ctx.row("`validate --require watertight` an empty .obj", &run, all([run.refused(&[]), run.within(5.0, 200.0)]));
    let p = ctx.write("noface.ply", "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n");
    let run = ctx.run(&["validate", "--require", "manifold", s(&p)], CAP);
    ctx.row(
        "`validate --require manifold` a PLY of 0 vertices and 0 faces",
        &run,
        all([run.refused(&[]), run.within(5.0, 200.0)]),
    );
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(Result::ok).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    v.sort();
    v
}

fn temporaries(dir: &Path) -> Vec<String> {
    names(dir).into_iter().filter(|n| n.starts_with(".octowrap-")).collect()
}

/// Outputs onto FIFOs, devices, links and the input itself; modes; signals.
fn writes(ctx: &mut Ctx) {
    let cube = ctx.write("w/cube.obj", CUBE_OBJ);
    writes_through(ctx, &cube);
    writes_refused_or_interrupted(ctx, &cube);
}

/// Outputs onto FIFOs, devices and links, and the modes of what they create or replace.
fn writes_through(ctx: &mut Ctx, cube: &Path) {
    // FIFOs: a reader must receive the mesh and the FIFO must stay one.
    for format in ["ply", "obj"] {
        let fifo = ctx.path(&format!("w/fifo.{format}"));
        if !Command::new("mkfifo").arg(&fifo).status().is_ok_and(|st| st.success()) {
            ctx.note("FIFO output", 0.0, Err("mkfifo unavailable: not measured".to_owned()));
            break;
        }
        let reader = Command::new("cat").arg(&fifo).stdout(Stdio::piped()).spawn();
        let run = ctx.run(&["convert", s(cube), s(&fifo)], Cap { secs: 10.0, mib: 512 });
        let kept = std::fs::symlink_metadata(&fifo).is_ok_and(|m| m.file_type().is_fifo());
        let mut got = Vec::new();
        if let Ok(mut reader) = reader {
            if !kept {
                let _ = reader.kill();
            }
            got = reader.wait_with_output().map(|o| o.stdout).unwrap_or_default();
        }
        let verdict = all([
            run.ok(),
            if kept { Ok(()) } else { Err("the FIFO was replaced by a regular file".to_owned()) },
            if got.is_empty() { Err("the reader got nothing".to_owned()) } else { Ok(()) },
        ]);
        ctx.row(format!("`convert` onto a FIFO (.{format})"), &run, verdict);
        let _ = std::fs::remove_file(&fifo);
    }
    // A character device made here (never the machine's own /dev/null).
    let null = ctx.path("w/null.ply");
    if Command::new("mknod")
        .arg(&null)
        .args(["c", "1", "3"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|st| st.success())
    {
        let before = std::fs::symlink_metadata(&null).map(|m| (m.ino(), m.rdev())).ok();
        for args in [vec!["convert", s(cube), s(&null)], vec!["convert", s(cube), s(&null), "--to", "stl"]] {
            let run = ctx.run(&args, Cap { secs: 10.0, mib: 512 });
            let after = std::fs::symlink_metadata(&null).ok();
            let kept =
                after.as_ref().is_some_and(|m| m.file_type().is_char_device() && Some((m.ino(), m.rdev())) == before);
            ctx.row(
                format!("`{}` onto a character device", args[3..].join(" ")),
                &run,
                all([run.ok(), if kept { Ok(()) } else { Err("the device node was replaced".to_owned()) }]),
            );
        }
        let _ = std::fs::remove_file(&null);
    } else {
        ctx.note("output onto a character device", 0.0, Err("mknod needs root: not measured".to_owned()));
    }
    // Symbolic links: the link stays, its target gets the data, the target's mode is kept.
    for (name, mode) in [("link.ply", 0o644), ("link.obj", 0o640)] {
        let target = ctx.write(&format!("w/target-{name}"), "old");
        let _ = std::fs::set_permissions(&target, std::fs::Permissions::from_mode(mode));
        let link = ctx.path(&format!("w/{name}"));
        let _ = std::fs::remove_file(&link);
        let _ = std::os::unix::fs::symlink(&target, &link);
        let run = ctx.run(&["convert", s(cube), s(&link)], Cap { secs: 10.0, mib: 512 });
        let is_link = std::fs::symlink_metadata(&link).is_ok_and(|m| m.file_type().is_symlink());
        let content = std::fs::read(&target).unwrap_or_default();
        let kept_mode = std::fs::metadata(&target).map_or(0, |m| m.mode() & 0o7777);
        let verdict = all([
            run.ok(),
            if is_link { Ok(()) } else { Err("the link was replaced by a file".to_owned()) },
            if content.len() > 3 { Ok(()) } else { Err("the link's target was not written".to_owned()) },
            if kept_mode == mode { Ok(()) } else { Err(format!("the target's mode {mode:o} became {kept_mode:o}")) },
        ]);
        ctx.row(format!("`convert` onto a symbolic link ({mode:o} target)"), &run, verdict);
    }
    // The umask and the mode of a replaced file.
    for umask in ["022", "077", "002"] {
        let out = ctx.path(&format!("w/umask{umask}.ply"));
        let mut cmd = Command::new("sh");
        cmd.arg("-c")
            .arg(format!("umask {umask}; exec \"$0\" convert \"$1\" \"$2\""))
            .arg(&ctx.bin)
            .arg(cube)
            .arg(&out);
        cmd.stdin(Stdio::null());
        let run = ctx.run_command(cmd, Cap { secs: 10.0, mib: 512 }, false);
        let want = 0o666 & !u32::from_str_radix(umask, 8).unwrap_or(0);
        let got = std::fs::metadata(&out).map_or(0, |m| m.mode() & 0o777);
        ctx.row(
            format!("new file under umask {umask}: mode {want:o}"),
            &run,
            all([run.ok(), if got == want { Ok(()) } else { Err(format!("mode {got:o}")) }]),
        );
    }
    for mode in [0o644, 0o664, 0o600] {
        let out = ctx.write(&format!("w/existing{mode:o}.ply"), "old");
        let _ = std::fs::set_permissions(&out, std::fs::Permissions::from_mode(mode));
        let run = ctx.run(&["convert", s(cube), s(&out)], Cap { secs: 10.0, mib: 512 });
        let got = std::fs::metadata(&out).map_or(0, |m| m.mode() & 0o777);
        ctx.row(
            format!("overwrite a {mode:o} file: mode kept"),
            &run,
            all([run.ok(), if got == mode { Ok(()) } else { Err(format!("mode {got:o}")) }]),
        );
    }
}

/// The output may not be the input; `--no-clobber`; a signal during a write.
fn writes_refused_or_interrupted(ctx: &mut Ctx, cube: &Path) {
    let wdir = ctx.path("w");
    // The output may not be the input, by any name.
    let ply = ctx.path("w/self.ply");
    let _ = ctx.run(&["convert", s(cube), s(&ply)], CAP);
    let hard = ctx.path("w/self-hard.ply");
    let _ = std::fs::hard_link(&ply, &hard);
    let soft = ctx.path("w/self-soft.ply");
    let _ = std::os::unix::fs::symlink(&ply, &soft);
    let dotted = format!("{}/./self.ply", s(&wdir));
    let before = std::fs::read(&ply).unwrap_or_default();
    for (case, args) in [
        ("`convert a.ply a.ply`", vec!["convert", s(&ply), s(&ply)]),
        ("`convert a.ply ./a.ply` (another spelling)", vec!["convert", s(&ply), dotted.as_str()]),
        ("`convert a.ply b.ply`, b a hard link to a", vec!["convert", s(&ply), s(&hard)]),
        ("`convert a.ply c.ply`, c a symbolic link to a", vec!["convert", s(&ply), s(&soft)]),
        ("`decimate a.ply -o a.ply`", vec!["decimate", s(&ply), "--ratio", "0.5", "-o", s(&ply)]),
    ] {
        let run = ctx.run(&args, CAP);
        let same = std::fs::read(&ply).unwrap_or_default() == before;
        ctx.row(
            case,
            &run,
            all([run.refused(&["self.ply"]), if same { Ok(()) } else { Err("the input was changed".to_owned()) }]),
        );
    }
    let pts = ctx.write("w/pts.xyz", unit_cube_xyz(500, 5));
    let before = std::fs::read(&pts).unwrap_or_default();
    let run = ctx.run(&["reconstruct", s(&pts), "-o", s(&pts)], CAP);
    let same = std::fs::read(&pts).unwrap_or_default() == before;
    ctx.row(
        "`reconstruct a.xyz -o a.xyz`",
        &run,
        all([run.refused(&["pts.xyz"]), if same { Ok(()) } else { Err("the input was changed".to_owned()) }]),
    );
    // --no-clobber.
    let existing = ctx.write("w/keep.obj", "keep");
    for args in [
        vec!["convert", "--no-clobber", s(cube), s(&existing)],
        vec!["decimate", "--no-clobber", s(cube), "--ratio", "0.5", "-o", s(&existing)],
    ] {
        let run = ctx.run(&args, CAP);
        let same = std::fs::read(&existing).unwrap_or_default() == b"keep";
        ctx.row(
            format!("`{} --no-clobber` onto an existing file", args[0]),
            &run,
            all([run.refused(&["keep.obj"]), if same { Ok(()) } else { Err("the file was replaced".to_owned()) }]),
        );
    }
    // A signal during a write: no temporary left, the conventional exit code.
    let n = 1_500_000u32;
    let mut big = ply_header(u64::from(n));
    for i in 0..n {
        for c in [i as f32, (i % 977) as f32 * 0.37, (i % 1013) as f32 * 0.11] {
            big.extend_from_slice(&c.to_le_bytes());
        }
    }
    let big = ctx.write("w/big.ply", big);
    let outdir = ctx.path("w/sig");
    let _ = std::fs::create_dir_all(&outdir);
    for (signal, code) in [("INT", 130), ("TERM", 143), ("INT", 130), ("TERM", 143)] {
        let output = outdir.join("big.xyz.gz");
        let started = Instant::now();
        let child = ctx.command(&["convert", s(&big), s(&output)]).stdout(Stdio::null()).stderr(Stdio::null()).spawn();
        let Ok(mut child) = child else { continue };
        let mut signalled = false;
        let mut status = None;
        while started.elapsed() < Duration::from_secs(60) {
            if !temporaries(&outdir).is_empty() {
                signalled = Command::new("kill")
                    .args([&format!("-{signal}"), &child.id().to_string()])
                    .status()
                    .is_ok_and(|st| st.success());
                break;
            }
            if let Ok(Some(st)) = child.try_wait() {
                status = Some(st);
                break;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        if status.is_none() && !signalled {
            let _ = child.kill();
        }
        let status = match status {
            Some(s) => Some(s),
            None => child.wait().ok(),
        };
        let left = temporaries(&outdir);
        let verdict = all([
            if signalled { Ok(()) } else { Err("no temporary seen to signal during".to_owned()) },
            if status.and_then(|s| s.code()) == Some(code) {
                Ok(())
            } else {
                Err(format!("exit {status:?}, wanted {code}"))
            },
            if left.is_empty() { Ok(()) } else { Err(format!("left {left:?}")) },
        ]);
        let run = Run { code: status.and_then(|s| s.code()), secs: started.elapsed().as_secs_f64(), ..Run::default() };
        ctx.row(format!("SIG{signal} while `convert` writes a .xyz.gz"), &run, verdict);
        let _ = std::fs::remove_file(&output);
    }
    let _ = std::fs::remove_file(&big);
}

/// Closed pipes, data and reports on standard output, compressed outputs.
fn streams(ctx: &mut Ctx) {
    let cube = ctx.write("s/cube.obj", CUBE_OBJ);
    let pts = ctx.write("s/pts.xyz", unit_cube_xyz(2000, 9));
    for (case, args) in [
        ("`info a b c | head -1` (pipe closed at once), 20 runs", vec!["info", s(&cube), s(&pts), s(&cube)]),
        ("`info --json a b | head -1`, 20 runs", vec!["info", "--json", s(&cube), s(&pts)]),
        ("`convert a.obj - --to obj | head -1`, 20 runs", vec!["convert", s(&cube), "-", "--to", "obj"]),
        ("`validate a b | head -1`, 20 runs", vec!["validate", s(&cube), s(&cube)]),
    ] {
        let t = Instant::now();
        let mut bad = Vec::new();
        for _ in 0..20 {
            let run = ctx.run_command(ctx.command(&args), Cap { secs: 10.0, mib: 512 }, true);
            // A report on standard error is fine (validate's summary goes there); a complaint
            // about the pipe is not.
            if let Err(e) = run.clean() {
                bad.push(e);
            } else if run.stderr.to_lowercase().contains("broken pipe") {
                bad.push(format!("says '{}' (exit {})", first_line(&run.stderr), run.exit()));
            }
        }
        let verdict = if bad.is_empty() { Ok(()) } else { Err(format!("{} of 20 runs: {}", bad.len(), bad[0])) };
        ctx.note(case, t.elapsed().as_secs_f64(), verdict);
    }
    let ply = ctx.path("s/cube.ply");
    let _ = ctx.run(&["convert", s(&cube), s(&ply)], CAP);
    for args in [
        vec!["decimate", s(&ply), "-o", "-", "--to", "ply", "--json", "--ratio", "0.5"],
        vec!["decimate", s(&ply), "-o", "-", "--to", "obj", "--json", "--ratio", "0.5", "--measure"],
        vec!["convert", s(&ply), "-", "--to", "ply"],
    ] {
        let run = ctx.run(&args, CAP);
        let out = run.stdout_text();
        let head_ok = out.starts_with("ply") || out.starts_with("v ") || out.starts_with('#') || out.starts_with("o ");
        let mixed = out.contains("\"faces\"") || out.contains("{\"") || out.contains("decimat");
        let verdict = if run.code == Some(0) {
            all([
                run.ok(),
                if head_ok { Ok(()) } else { Err(format!("stdout starts '{}'", first_line(&out))) },
                if mixed { Err("the report shares stdout with the mesh".to_owned()) } else { Ok(()) },
            ])
        } else {
            run.refused(&["standard output"])
        };
        ctx.row(
            format!(
                "`{}`: stdout holds the data only",
                args.iter().map(|a| a.rsplit('/').next().unwrap_or(a)).collect::<Vec<_>>().join(" ")
            ),
            &run,
            verdict,
        );
    }
    for ext in ["ply.gz", "obj.gz", "stl.gz", "xyz.gz", "off.gz"] {
        let out = ctx.path(&format!("s/out.{ext}"));
        let run = ctx.run(&["convert", s(&cube), s(&out)], CAP);
        let bytes = std::fs::read(&out).unwrap_or_default();
        let gz = bytes.starts_with(&[0x1f, 0x8b]);
        let back = if gz { ctx.run(&["info", s(&out)], CAP).ok() } else { Ok(()) };
        ctx.row(
            format!("`convert a.obj out.{ext}` is gzip and reads back"),
            &run,
            all([run.ok(), if gz { Ok(()) } else { Err("not gzip".to_owned()) }, back]),
        );
    }
}

/// Options out of range are refused before any work.
fn options(ctx: &mut Ctx) {
    let sphere = ctx.write("o/sphere.xyz", sphere_xyz(200_000));
    let ply = ctx.write("o/cube.obj", CUBE_OBJ);
    let run = ctx.run(&["reconstruct", s(&sphere), "-o", "o/full.mrq"], Cap { secs: 120.0, mib: 4096 });
    let baseline = run.secs;
    ctx.row("`reconstruct` 200,000 points (the work a refusal must not do first)", &run, run.ok());
    let sp = s(&sphere);
    for (case, args, needle) in [
        ("`reconstruct --bits 0`", vec!["reconstruct", sp, "-o", "o/b.mrq", "--bits", "0"], "bits"),
        ("`reconstruct --bits 40`", vec!["reconstruct", sp, "-o", "o/b.mrq", "--bits", "40"], "bits"),
        (
            "`reconstruct --write-level 9`",
            vec!["reconstruct", sp, "-o", "o/b.mrq", "--write-level", "9"],
            "write-level",
        ),
        ("`reconstruct --zstd-level 0`", vec!["reconstruct", sp, "-o", "o/b.mrq", "--zstd-level", "0"], "zstd-level"),
        ("`reconstruct --zstd-level 23`", vec!["reconstruct", sp, "-o", "o/b.mrq", "--zstd-level", "23"], "zstd-level"),
        (
            "`reconstruct -o out.ply --bits 12` (bits mean nothing in PLY)",
            vec!["reconstruct", sp, "-o", "o/b.ply", "--bits", "12"],
            "bits",
        ),
        ("`reconstruct --max-level 40`", vec!["reconstruct", sp, "-o", "o/b.mrq", "--max-level", "40"], "max-level"),
        ("`reconstruct --threads 0`", vec!["reconstruct", sp, "-o", "o/b.mrq", "--threads", "0"], "threads"),
        (
            "`decimate --target-faces 0`",
            vec!["decimate", s(&ply), "-o", "o/d.obj", "--target-faces", "0"],
            "target-faces",
        ),
        ("`decimate --ratio 1.5`", vec!["decimate", s(&ply), "-o", "o/d.obj", "--ratio", "1.5"], "ratio"),
        ("`decimate --max-error -1`", vec!["decimate", s(&ply), "-o", "o/d.obj", "--max-error", "-1"], "max-error"),
        ("`export --screen-error 0`", vec!["export", s(&ply), "-o", "o/e.glb", "--screen-error", "0"], "screen-error"),
        ("`--max-memory 0`", vec!["info", "--max-memory", "0", s(&ply)], "max-memory"),
        ("`--max-scans 0`", vec!["info", "--max-scans", "0", s(&ply)], "max-scans"),
    ] {
        let run = ctx.run(&args, Cap { secs: 120.0, mib: 4096 });
        let fast = (baseline * 0.1).max(0.3);
        ctx.row(case, &run, all([run.refused(&[needle]), run.within(fast, 500.0)]));
    }
    let _ = std::fs::remove_file(&sphere);
}

/// Error messages name the right file and say what is wrong.
fn messages(ctx: &mut Ctx) {
    let mut ply = ply_header(1000);
    ply.extend(std::iter::repeat_n(0u8, 5000));
    let broken_ply = ctx.write("m/broken.ply", &ply);
    let broken_obj = ctx.write("m/broken.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n");
    let broken_stl = ctx.write("m/broken.stl", {
        let mut b = vec![0u8; 80];
        b.extend_from_slice(&1000u32.to_le_bytes());
        b.extend(vec![0u8; 500]);
        b
    });
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut mrq = std::fs::read(root.join("fixtures/format/valid/cube3_lattice_q12.mrq")).unwrap_or_default();
    if let Some(b) = mrq.last_mut() {
        *b ^= 0x55;
    }
    let broken_mrq = ctx.write("m/broken.mrq", mrq);
    for (case, input) in [
        ("truncated binary PLY", &broken_ply),
        ("OBJ face index 99 of 3", &broken_obj),
        ("truncated STL", &broken_stl),
        ("MRQ with a bad checksum", &broken_mrq),
    ] {
        let name = input.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let run = ctx.run(&["convert", s(input), "m/result-file.obj"], CAP);
        let blames_output = run.stderr.contains("result-file");
        ctx.row(
            format!("`convert` a {case}: the message names the input"),
            &run,
            all([
                run.refused(&[&name]),
                if blames_output { Err(format!("blames the output: {}", first_line(&run.stderr))) } else { Ok(()) },
            ]),
        );
    }
    let degenerate = ctx.write("m/degenerate.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n".to_owned() + &"f 1 1 1\n".repeat(100));
    let run = ctx.run(&["export", s(&degenerate), "-o", "m/result-file.glb"], CAP);
    let blames_output = run.stderr.contains("result-file");
    ctx.row(
        "`export` a mesh of degenerate triangles: the message names the input",
        &run,
        all([
            run.refused(&["degenerate.obj"]),
            if blames_output { Err(format!("blames the output: {}", first_line(&run.stderr))) } else { Ok(()) },
        ]),
    );
    let mut denormal = String::new();
    for i in 0..3000u32 {
        let _ = writeln!(
            denormal,
            "{:e} {:e} {:e}",
            f64::from(i) * 1e-310,
            f64::from(i % 17) * 1e-310,
            f64::from(i % 13) * 1e-310
        );
    }
    let den = ctx.write("m/denormal.xyz", denormal);
    let run = ctx.run(&["reconstruct", s(&den), "-o", "m/den.mrq"], CAP);
    let wrong = run.stderr.contains("only 1 distinct");
    ctx.row(
        "`reconstruct` 3,000 distinct denormal points: no 'only 1 distinct point'",
        &run,
        all([run.clean(), if wrong { Err(first_line(&run.stderr)) } else { Ok(()) }]),
    );
    messages_of_streams_and_sets(ctx, &ply, &den);
}

/// gzip errors at their real offsets, a missing target named, every file of a folder or a list
/// reported.
fn messages_of_streams_and_sets(ctx: &mut Ctx, ply: &[u8], den: &Path) {
    // gzip errors at their real offset.
    let mut obj = String::new();
    for i in 0..20_000 {
        let _ = writeln!(obj, "v {i} {} {}", i % 7, i % 11);
    }
    let gz = gzip(obj.as_bytes());
    let mut flipped = gz.clone();
    let mid = flipped.len() / 2;
    for b in &mut flipped[mid..mid + 16] {
        *b ^= 0xa5;
    }
    let truncated = &gz[..gz.len() * 2 / 3];
    let mut bad_crc = gz.clone();
    let n = bad_crc.len();
    bad_crc[n - 8] ^= 1;
    for (case, bytes) in [
        ("corrupt in the middle", flipped),
        ("truncated at two thirds", truncated.to_vec()),
        ("with a wrong CRC", bad_crc),
    ] {
        let p = ctx.write("m/bad.obj.gz", bytes);
        let run = ctx.run(&["info", s(&p)], CAP);
        let err = run.stderr.clone();
        let at_zero = err.contains("byte 0 ")
            || err.contains("byte 0:")
            || err.contains("byte 0)")
            || err.trim_end().ends_with("byte 0");
        ctx.row(
            format!("`info` a .obj.gz {case}: the offset is not 'byte 0'"),
            &run,
            all([run.refused(&["bad.obj.gz"]), if at_zero { Err(first_line(&err)) } else { Ok(()) }]),
        );
    }
    let cube = ctx.write("m/cube.obj", CUBE_OBJ);
    let run = ctx.run(&["decimate", s(&cube), "-o", "m/d.obj"], CAP);
    ctx.row(
        "`decimate` without a target names every way to give one",
        &run,
        run.refused(&["--target-faces", "--ratio", "--max-error"]),
    );
    // A folder with a file whose name is not UTF-8.
    let vdir = ctx.path("m/dir");
    let _ = std::fs::create_dir_all(&vdir);
    let _ = std::fs::write(vdir.join("good.obj"), CUBE_OBJ);
    let odd = vdir.join(OsStr::from_bytes(b"odd-\xff.obj"));
    let odd_written = std::fs::write(&odd, CUBE_OBJ).is_ok();
    let run = ctx.run(&["validate", s(&vdir)], CAP);
    let text = run.all_lower();
    let reported = text.contains("odd-");
    ctx.row(
        "`validate DIR` with a non-UTF-8 file name reports that file",
        &run,
        all([
            run.clean(),
            if odd_written && reported { Ok(()) } else { Err("the odd name is not in the output".to_owned()) },
        ]),
    );
    let bad = ctx.write("m/middle.ply", ply);
    let run = ctx.run(&["info", "--json", s(&cube), s(&bad), s(den)], CAP);
    let out = run.stdout_text();
    let both = out.contains("cube.obj") && out.contains("denormal.xyz");
    ctx.row(
        "`info --json a bad c` reports every file",
        &run,
        all([
            run.refused(&["middle.ply"]),
            if both { Ok(()) } else { Err("not every good file is in the JSON".to_owned()) },
        ]),
    );
}

/// Every subcommand states the ceiling in its help, and the ceiling holds.
fn ceiling(ctx: &mut Ctx) {
    let help = ctx.run(&["--help"], CAP);
    let text = help.stdout_text();
    let subcommands: Vec<String> = text
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  ") || l.is_empty())
        // A command's name is indented two spaces; its wrapped description more.
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .filter(|c| c != "help")
        .collect();
    if subcommands.is_empty() {
        ctx.note("`octowrap --help` lists the subcommands", help.secs, Err("no 'Commands:' section".to_owned()));
    }
    let mut missing = Vec::new();
    for c in &subcommands {
        let run = ctx.run(&[c, "--help"], CAP);
        if !run.stdout_text().contains("--max-memory") {
            missing.push(c.clone());
        }
    }
    let verdict =
        if missing.is_empty() { Ok(()) } else { Err(format!("no --max-memory in the help of {}", missing.join(", "))) };
    ctx.note(format!("`--max-memory` in the help of all {} subcommands", subcommands.len()), 0.0, verdict);
    let xyz = ctx.write("c/pts.xyz", unit_cube_xyz(200_000, 11));
    let cube = ctx.write("c/cube.obj", CUBE_OBJ);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mrq = root.join("fixtures/format/valid/cube3_lattice_q12.mrq");
    let m = s(&mrq);
    for (case, args) in [
        ("`info --max-memory 1M` 200,000 points", vec!["info", "--max-memory", "1M", s(&xyz)]),
        (
            "`reconstruct --max-memory 1M` 200,000 points",
            vec!["reconstruct", "--max-memory", "1M", s(&xyz), "-o", "c/r.mrq"],
        ),
        ("`convert --max-memory 1K` an MRQ", vec!["convert", "--max-memory", "1K", m, "c/x.ply"]),
        ("`validate --max-memory 1K` an MRQ", vec!["validate", "--max-memory", "1K", m]),
        (
            "`decimate --max-memory 1K` an MRQ",
            vec!["decimate", "--max-memory", "1K", m, "--ratio", "0.5", "-o", "c/d.obj"],
        ),
        ("`export --max-memory 1K` an OBJ", vec!["export", "--max-memory", "1K", s(&cube), "-o", "c/e.glb"]),
        ("`extract --max-memory 1K` an MRQ", vec!["extract", "--max-memory", "1K", m, "-o", "c/x.obj"]),
    ] {
        let run = ctx.run(&args, CAP);
        ctx.row(case, &run, all([run.refused(&["max-memory"]), run.within(5.0, 200.0)]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peak_of_a_live_process_is_read() {
        let (hwm, rss) = memory_of(std::process::id()).unwrap();
        assert!(rss > 0 && hwm >= rss, "VmHWM {hwm} KiB, VmRSS {rss} KiB");
        assert_eq!(memory_of(u32::MAX), None);
    }

    #[test]
    fn a_refusal_needs_a_clean_nonzero_exit_and_every_word() {
        let run = |code, stderr: &str| Run { code: Some(code), stderr: stderr.to_owned(), ..Run::default() };
        assert!(run(2, "error: a.ply: trailing data").refused(&["a.ply", "TRAILING"]).is_ok());
        assert!(run(2, "error: a.ply: trailing data").refused(&["b.ply"]).is_err());
        assert!(run(0, "").refused(&[]).is_err(), "exit 0 is no refusal");
        assert!(run(101, "thread 'main' panicked at src/x.rs").refused(&[]).is_err());
        assert!(run(134, "memory allocation of 8589934592 bytes failed").clean().is_err());
        let killed = Run { capped: Some("time cap"), ..Run::default() };
        assert!(killed.ok().is_err() && killed.exit() == "killed (time cap)");
    }

    #[test]
    fn polygons_have_the_corners_asked_for() {
        for shape in ["pairs", "laps", "point", "collinear"] {
            let obj = polygon_obj(3000, shape);
            let face = obj.lines().find(|l| l.starts_with("f ")).unwrap();
            assert_eq!(face.split_whitespace().count() - 1, 3000, "{shape}");
            let distinct = obj.lines().filter(|l| l.starts_with("v ")).count();
            assert_eq!(
                distinct,
                [1500, 1000, 1, 3000]
                    [["pairs", "laps", "point", "collinear"].iter().position(|s| *s == shape).unwrap()]
            );
        }
    }
}
