//! Entropy coding of value sequences (spec §6.9 Coded value blocks): an adaptive binary range
//! coder (`range`) and the value blocks built on it (`values`), used by the geometry streams of
//! version 4 files.

pub mod range;
pub mod values;
