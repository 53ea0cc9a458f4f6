//! Geometry of a level (spec §6): `predict` (modes 0-2: context, passes, predictors, §6.2-§6.5,
//! §6.7), `lines` (§6.6), `fixed` (mode 3's integer geometry, §6.8), `residuals` (the
//! stream's layout, §6.1, §6.6) and `decoder_lines` (mode 3's lines for a producer that builds a
//! hierarchy on them).

pub mod decoder_lines;
pub mod fixed;
pub mod lines;
pub mod predict;
pub mod residuals;
