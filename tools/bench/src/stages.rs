//! The per-level stage times of a reconstruction, shared by the bench's report and the
//! `recon_big` example (which includes this file by path: the bench has no library target).

use std::fmt::Write as _;

use octowrap_recon::Reconstruction;

/// The stages of a level, in the order they run, then their total.
const STAGES: [&str; 6] = ["partitioning", "regular", "irregular", "mapping", "relaxation", "total"];

/// One row per level: the level, its kind, its face count, then the seconds of each of `STAGES`.
fn stage_rows(r: &Reconstruction) -> impl Iterator<Item = (String, [f64; 6])> + '_ {
    r.levels.iter().map(|l| {
        let t = &l.timings;
        let secs =
            [t.partitioning, t.regular, t.irregular, t.mapping, t.relaxation, t.total()].map(|d| d.as_secs_f64());
        (format!("{} {:?} {}", l.level, l.kind, l.faces), secs)
    })
}

/// Per-level, per-stage seconds as a markdown table.
pub fn stage_table(r: &Reconstruction) -> String {
    let mut s =
        format!("| level | kind | faces | {} |\n|---|---|---|{}\n", STAGES.join(" | "), "---|".repeat(STAGES.len()));
    for (level, secs) in stage_rows(r) {
        let cells: Vec<String> = secs.iter().map(|x| format!("{x:.3}")).collect();
        let _ = writeln!(s, "| {} | {} |", level.replace(' ', " | "), cells.join(" | "));
    }
    s
}
