//! Fuzzing: what the last campaign of `tools/fuzz/run.sh` reached per target, read from its logs
//! (`tools/fuzz/logs/TARGET.log`, libFuzzer's fork-mode statistics). The campaign itself runs for
//! hours, so this area reports it rather than running it: `tools/fuzz/run.sh -n 10000000` first.

use std::path::{Path, PathBuf};

use crate::util::headline;

/// The campaign's goal per target.
const GOAL_EXECUTIONS: u64 = 10_000_000;

/// A target's last statistics line: executions, ooms, timeouts, crashes, seconds.
#[derive(Debug, Default, PartialEq, Eq)]
struct Reached {
    executions: u64,
    ooms: u64,
    timeouts: u64,
    crashes: u64,
    seconds: u64,
}

/// The last `#EXECS: ... oom/timeout/crash: O/T/C time: Ns ...` line of a fork-mode log.
fn last_statistics(log: &str) -> Option<Reached> {
    let line = log.lines().rev().find(|l| l.starts_with('#') && l.contains("oom/timeout/crash:"))?;
    let executions = line[1..].split(':').next()?.parse().ok()?;
    let field = |name: &str| line.split(name).nth(1)?.split_whitespace().next();
    let mut otc = field("oom/timeout/crash:")?.split('/').map(str::parse::<u64>);
    let (ooms, timeouts, crashes) = (otc.next()?.ok()?, otc.next()?.ok()?, otc.next()?.ok()?);
    let seconds = field("time:")?.trim_end_matches('s').parse().ok()?;
    Some(Reached { executions, ooms, timeouts, crashes, seconds })
}

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

/// The files libFuzzer left in `artifacts/TARGET/` (crashes, ooms, timeouts).
fn artifacts(target: &str) -> usize {
    std::fs::read_dir(fuzz_dir().join("artifacts").join(target)).map_or(0, |d| d.filter_map(Result::ok).count())
}

pub fn report() {
    outln!("## Fuzzing\n");
    let logs = fuzz_dir().join("logs");
    let mut targets: Vec<(String, String)> = std::fs::read_dir(&logs)
        .into_iter()
        .flatten()
        .filter_map(Result::ok)
        .filter_map(|e| {
            // TARGET.log, not TARGET.build.log.
            let path = e.path();
            let stem = Path::new(path.file_stem()?);
            if path.extension()? != "log" || stem.extension().is_some() {
                return None;
            }
            Some((stem.to_string_lossy().into_owned(), std::fs::read_to_string(&path).ok()?))
        })
        .collect();
    targets.sort();
    if targets.is_empty() {
        outln!("no campaign logs in {}: run tools/fuzz/run.sh -n {GOAL_EXECUTIONS} first", logs.display());
        headline("fuzz campaign", "not measured: no logs in tools/fuzz/logs", "≥ 10 M executions per target", None);
        return;
    }
    outln!("The last campaign of `tools/fuzz/run.sh` (libFuzzer fork mode, `-rss_limit_mb=512 -malloc_limit_mb=512");
    outln!("-timeout=10`, crashes, ooms and timeouts counted, not fatal), per target:\n");
    outln!("| target | executions | seconds | executions/s | ooms | timeouts | crashes | artifacts |");
    outln!("|---|---|---|---|---|---|---|---|");
    for (target, log) in &targets {
        let Some(r) = last_statistics(log) else {
            outln!("| {target} | no statistics in its log | | | | | | |");
            headline(format!("fuzz `{target}`"), "not measured: no statistics in its log", "≥ 10 M; 0 found", None);
            continue;
        };
        let found = artifacts(target);
        let rate = r.executions / r.seconds.max(1);
        outln!(
            "| {target} | {} | {} | {rate} | {} | {} | {} | {found} |",
            r.executions,
            r.seconds,
            r.ooms,
            r.timeouts,
            r.crashes
        );
        let clean = r.ooms + r.timeouts + r.crashes == 0 && found == 0;
        headline(
            format!("fuzz `{target}`: executions; crashes / ooms / timeouts"),
            format!("{} in {} s; {} / {} / {}", r.executions, r.seconds, r.crashes, r.ooms, r.timeouts),
            "≥ 10 M; 0 / 0 / 0",
            Some(clean && r.executions >= GOAL_EXECUTIONS),
        );
    }
    outln!();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_fork_mode_statistics_line_is_read() {
        let log = "INFO: -fork=1\n\
                   #1000: cov: 10 ft: 12 corp: 3 exec/s: 500 oom/timeout/crash: 0/0/0 time: 2s job: 1 dft_time: 0\n\
                   #5395294: cov: 118 ft: 145 corp: 41 exec/s: 12016 oom/timeout/crash: 1/2/3 time: 449s job: 9 dft_time: 0\n\
                   INFO: fuzzed for 449 seconds, wrapping up soon\n";
        let r = last_statistics(log).unwrap();
        assert_eq!(r, Reached { executions: 5_395_294, ooms: 1, timeouts: 2, crashes: 3, seconds: 449 });
        assert_eq!(last_statistics("INFO: nothing yet\n"), None);
    }
}
