//! Temporary phase profiling (not landed).
#![allow(missing_docs, clippy::pedantic)]
use std::cell::Cell;
thread_local! {
    static LAST: Cell<f64> = const { Cell::new(0.0) };
    static ACC: Cell<[f64; 8]> = const { Cell::new([0.0; 8]) };
}
fn cpu() -> f64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    s.split_whitespace().next().and_then(|x| x.parse::<f64>().ok()).unwrap_or(0.0) * 1e-9
}
pub fn ph(i: usize) {
    if std::env::var_os("PHASES").is_none() { return; }
    let now = cpu();
    let d = now - LAST.with(Cell::get);
    LAST.with(|l| l.set(now));
    ACC.with(|a| { let mut v = a.get(); v[i] += d; a.set(v); });
}
pub fn start() { if std::env::var_os("PHASES").is_some() { LAST.with(|l| l.set(cpu())); } }
pub fn dump(names: &str) {
    if std::env::var_os("PHASES").is_none() { return; }
    let v = ACC.with(|a| a.replace([0.0; 8]));
    let s: Vec<String> = names.split(' ').zip(v).map(|(n, x)| format!("{n} {x:.3}")).collect();
    eprintln!("{}", s.join(" "));
}
